#pragma once
// Writes index records on its own thread, in transactions of at most
// `batch_period` (default 250 ms): producers push without waiting; a crash loses
// at most the open batch. Records are held in a bounded queue sized for many
// seconds of every stream; if it ever fills (the index fell behind), records wait in the
// overflow (storage/writer/index_overflow.h: memory, then the spill folder) in their order until the
// index has caught up, and an index_behind event says how many waited: none is dropped. A batch
// that fails because the disk is full is held, and written once more at stop(): the session
// writer frees its space reserve first, so what was captured before the disk filled is not lost
// with it. Records are lost (counted by kind) only after a storage failure. A copy of every record
// goes to the journal (storage/writer/index_journal.h) until it is committed: a crash while the index is
// behind loses none that `pvcap recover` cannot write.
#include <array>
#include <atomic>
#include <chrono>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <variant>

#include "core/bounded_queue.h"
#include "core/fault_injection.h"
#include "storage/index/session_index.h"
#include "storage/writer/index_journal.h"
#include "storage/writer/index_overflow.h"

namespace pvcap {

class IndexWriter {
 public:
  using Record = IndexQueueItem;

  static constexpr std::size_t kQueueRecords = 200'000;

  // `stall`: a test's fault (core/fault_injection.h), the index thread sleeps once. `overflow_file`:
  // where records wait on disk when the queue and the overflow's memory are full (none: memory only).
  // `journal_folder`: where the journal's files go (none: no journal).
  IndexWriter(SessionIndex& index, std::size_t capacity = kQueueRecords,
              std::chrono::milliseconds batch_period = std::chrono::milliseconds(250), std::optional<Stall> stall = {},
              std::filesystem::path overflow_file = {},
              std::size_t overflow_memory_records = IndexOverflow::kMemoryRecords,
              std::filesystem::path journal_folder = {});
  ~IndexWriter();

  void start();
  // Never waits on I/O. False (the record counted as lost) only after a storage failure or stop().
  bool push(Record record);
  // Pushes `record` and waits until it is committed to the index (at most `timeout`): for what
  // must be on disk before it is acknowledged (protocol transitions). Not for capture threads.
  bool push_committed(Record record, std::chrono::milliseconds timeout);
  // Writes what is queued and stops the thread.
  void stop();
  // Set when writing failed (e.g. disk full): the message names the file and the cause.
  std::optional<std::string> failure() const;
  // Set when the journal or the overflow's file failed (the index itself went on): their file and
  // the cause. A disk that fails them is failing.
  std::optional<std::string> side_failure() const {
    if (journal_)
      if (auto f = journal_->failure()) return f;
    return overflow_.failure();
  }
  std::uint64_t records_written() const { return written_.load(); }
  std::uint64_t records_lost() const { return lost_.load() + overflow_.lost(); }
  // Records that waited in the overflow (the index was behind), and of them went through its file.
  std::uint64_t records_waited() const { return waited_.load(); }
  std::uint64_t records_waited_on_disk() const { return overflow_.spilled(); }
  // "frames 12, pressure frames 40": what the lost records were (empty when none was lost).
  std::string lost_records_by_kind() const;

 private:
  void run();
  // The overflow's oldest records when the queue is empty; false once nothing waits there.
  bool take_overflow(std::vector<Record>& items);
  void write_batch(std::vector<Record>& batch);
  void write_records(const std::vector<Record>& batch);
  // A record the index thread adds itself (not pushed: not in the journal's count).
  void add_own(std::vector<Record>& batch, EventRecord event);

  SessionIndex& index_;
  BoundedQueue<Record> queue_;
  const std::size_t queue_capacity_;
  const std::chrono::milliseconds batch_period_;
  const std::optional<Stall> stall_;
  std::thread thread_;
  std::atomic<std::uint64_t> written_{0}, lost_{0}, waited_{0};
  // While the overflow holds records every new one goes there too (order); set and cleared under push_mu_.
  std::mutex push_mu_;
  std::atomic<bool> overflowing_{false};
  std::atomic<std::int64_t> behind_since_ns_{0};              // when the latest overflow began
  std::uint64_t waited_reported_ = 0, spilled_reported_ = 0;  // the index thread's, for its events
  IndexOverflow overflow_;
  std::array<std::atomic<std::uint64_t>, std::variant_size_v<Record>> lost_by_kind_{};
  std::atomic<bool> failed_{false}, disk_full_{false};
  mutable std::mutex failure_mu_;
  std::optional<std::string> failure_;
  std::vector<Record> held_;  // the batch that met a full disk
  std::unique_ptr<IndexJournal> journal_;
  std::size_t own_in_batch_ = 0;        // the index thread's: records of the open batch not pushed
  std::uint64_t pushed_committed_ = 0;  // the index thread's: pushed records committed (in push order)
};

}  // namespace pvcap
