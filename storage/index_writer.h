#pragma once
// Writes index records on its own thread, in transactions of at most
// `batch_period` (default 250 ms): producers push without waiting; a crash loses
// at most the open batch. Records are held in a bounded queue sized for many
// seconds of every stream; if it ever fills, the overflow is counted by kind
// and written as an index_overflow event when there is room again. A batch that fails because
// the disk is full is held, and written once more at stop(): the session writer
// frees its space reserve first, so what was captured before the disk filled is
// not lost with it.
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
#include "storage/session_index.h"

namespace pvcap {

// In the queue: "commit everything before me now, then tell". Never written itself.
struct CommitBarrier {
  std::shared_ptr<std::promise<bool>> committed;  // true once committed; false if writing failed
};

class IndexWriter {
 public:
  using Record = std::variant<FrameRecord, PressureRecord, DropRecord, EventRecord, SampleRecord, ClockModelRecord,
                              VideoFileRecord, VideoFileClosed, ProtocolEventRecord, OperatorNoteRecord, CommitBarrier>;

  static constexpr std::size_t kQueueRecords = 200'000;

  // `stall`: a test's fault (core/fault_injection.h), the index thread sleeps once.
  IndexWriter(SessionIndex& index, std::size_t capacity = kQueueRecords,
              std::chrono::milliseconds batch_period = std::chrono::milliseconds(250), std::optional<Stall> stall = {});
  ~IndexWriter();

  void start();
  // False when the queue is full (the record is counted as lost) or after a failure.
  bool push(Record record);
  // Pushes `record` and waits until it is committed to the index (at most `timeout`): for what
  // must be on disk before it is acknowledged (protocol transitions). Not for capture threads.
  bool push_committed(Record record, std::chrono::milliseconds timeout);
  // Writes what is queued and stops the thread.
  void stop();
  // Set when writing failed (e.g. disk full): the message names the file and the cause.
  std::optional<std::string> failure() const;
  std::uint64_t records_written() const { return written_.load(); }
  std::uint64_t records_lost() const { return lost_.load(); }
  // "frames 12, pressure frames 40": what the lost records were (empty when none was lost).
  std::string lost_records_by_kind() const;

 private:
  void run();
  void write_batch(std::vector<Record>& batch);
  void write_records(const std::vector<Record>& batch);

  SessionIndex& index_;
  BoundedQueue<Record> queue_;
  const std::size_t queue_capacity_;
  const std::chrono::milliseconds batch_period_;
  const std::optional<Stall> stall_;
  std::thread thread_;
  std::atomic<std::uint64_t> written_{0}, lost_{0};
  std::array<std::atomic<std::uint64_t>, std::variant_size_v<Record>> lost_by_kind_{};
  std::atomic<bool> failed_{false}, disk_full_{false};
  mutable std::mutex failure_mu_;
  std::optional<std::string> failure_;
  std::vector<Record> held_;  // the batch that met a full disk
};

}  // namespace pvcap
