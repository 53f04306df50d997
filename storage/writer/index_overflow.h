#pragma once
// Where index records wait when the index's queue is full (the index thread fell behind: a slow
// disk, a busy machine): in memory up to a bound, then in a file of the session's spill folder,
// written by a thread of its own, so no record is dropped and no device thread waits for a disk.
// Records leave in the order they came (the file's first, then memory's) once the index thread
// has emptied its queue. A commit barrier that would have to go to the file is answered "not
// committed" instead: whoever waits on it has waited too long already.
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "core/result.h"
#include "storage/index/record_codec.h"

namespace pvcap {

// In the index's queue: "commit everything before me now, then tell". Never written itself.
struct CommitBarrier {
  std::shared_ptr<std::promise<bool>> committed;  // true once committed; false if writing failed
};

// An index record or a barrier (IndexRecord's kinds in its order, then CommitBarrier).
using IndexQueueItem =
    std::variant<FrameRecord, PressureRecord, DropRecord, EventRecord, SampleRecord, ClockModelRecord, VideoFileRecord,
                 VideoFileClosed, ProtocolEventRecord, OperatorNoteRecord, CommitBarrier>;

// In the session's spill folder while the index is behind; removed once read back.
inline constexpr const char* kIndexOverflowFile = "index-rows.overflow";

// The records of a file of record chunks (the overflow, the journal: storage/index/record_codec.h) and
// how many bytes at its end a crash cut. `pvcap recover` reads them to write the rows into the
// index (storage/writer/recover.h).
Result<RecordChunks> read_record_file(const std::filesystem::path& file);

class IndexOverflow {
 public:
  static constexpr std::size_t kMemoryRecords = 20'000;
  // `file`: where records beyond `memory_records` wait (made when first needed, removed once
  // empty); empty path: memory only.
  explicit IndexOverflow(std::filesystem::path file, std::size_t memory_records = kMemoryRecords);
  ~IndexOverflow();
  IndexOverflow(const IndexOverflow&) = delete;
  IndexOverflow& operator=(const IndexOverflow&) = delete;

  // Any thread; never waits on I/O (a short lock).
  void add(IndexQueueItem item);
  // The oldest records waiting: the file's next chunk, or everything in memory; empty when nothing
  // waits. A chunk on its way to the file lands first (order). The index thread only.
  std::vector<IndexQueueItem> take();
  bool empty() const;
  std::uint64_t spilled() const;               // records that went through the file so far
  std::optional<std::string> failure() const;  // the file failed (its records are lost; counted)
  std::uint64_t lost() const;

 private:
  void spill_loop();
  bool write_chunk(std::vector<IndexQueueItem>& items);  // consumes them
  std::vector<IndexQueueItem> read_chunk(std::int64_t offset, std::size_t size);

  const std::filesystem::path file_;
  const std::size_t memory_records_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::deque<IndexQueueItem> memory_;
  std::size_t in_flight_ = 0;                                // taken by the spill thread, not yet in the file
  std::deque<std::pair<std::int64_t, std::size_t>> chunks_;  // in the file, unread: (offset, bytes)
  std::int64_t end_ = 0;                                     // the file's length
  std::uint64_t spilled_ = 0, lost_ = 0;
  int fd_ = -1;
  std::optional<std::string> failure_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace pvcap
