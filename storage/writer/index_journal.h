#pragma once
// The journal of index rows not yet committed: a copy of every row the index writer accepts is
// appended, on a thread of its own, to a file of the session's spill folder within milliseconds
// (synced with the folder's other files once a second: core/durable_folder.h); the index writer
// says how many rows it has committed, and a file whose rows are all committed is removed. So when
// the recorder is killed, or the power goes, while the index is behind (a slow disk, a busy machine:
// rows wait in its queue and overflow, in memory), `pvcap recover` finds the rows the index lacks
// here and writes them into it (storage/writer/recover.h): every frame that reached the disk keeps its row.
//
// Files are numbered (index-rows.journal.<n>, one per second at most) so that the committed ones can
// be removed whole; a crash cuts at most the last chunk of the last one (storage/index/record_codec.h).
// The journal is a safety net beside the index, never in its way: it never blocks a producer, and
// when it cannot keep up (more than kPendingBytes waiting) or its disk fails, it stops, says so once,
// and keeps what it has.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "storage/index/record_codec.h"

namespace pvcap {

inline constexpr const char* kIndexJournalPrefix = "index-rows.journal.";

// A session's journal files in the order they were written (the number after the prefix).
std::vector<std::filesystem::path> index_journal_files(const std::filesystem::path& spill_folder);

class IndexJournal {
 public:
  static constexpr std::size_t kPendingBytes = 256u << 20;
  static constexpr std::chrono::milliseconds kFilePeriod{1000};

  // `folder`: where the files go (made when the first row comes); `file_period`: how long one file is
  // written at most.
  explicit IndexJournal(std::filesystem::path folder, std::chrono::milliseconds file_period = kFilePeriod);
  ~IndexJournal();
  IndexJournal(const IndexJournal&) = delete;
  IndexJournal& operator=(const IndexJournal&) = delete;

  // Any thread; never waits on I/O (a short lock). Rows are counted in the order they come: the
  // index writer calls it under the lock that orders its own queue.
  void append(IndexRecord record);
  // The index has committed the first `rows` rows appended: files holding only those may go.
  void committed(std::uint64_t rows);
  // Something was lost on the index's side: every file stays, for `pvcap recover`.
  void keep_all();
  // Ends the thread; `remove_files` when the index holds every row (a clean stop).
  void stop(bool remove_files);

  std::optional<std::string> failure() const;
  std::uint64_t rows_appended() const { return appended_.load(); }

 private:
  struct File {
    std::filesystem::path path;
    std::uint64_t end_row = 0;  // rows appended up to and with this file's last
  };
  void run();
  bool write_out(std::vector<IndexRecord>& rows);
  bool open_next_file();
  void remove_committed_files();
  void fail(const std::string& why);

  const std::filesystem::path folder_;
  const std::chrono::milliseconds file_period_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::vector<IndexRecord> pending_;
  std::size_t pending_bytes_ = 0;
  bool stopping_ = false, stopped_taking_ = false;
  std::optional<std::string> failure_;
  std::atomic<std::uint64_t> appended_{0}, committed_{0};
  std::atomic<bool> keep_all_{false};

  // The journal thread's.
  std::deque<File> files_;  // written, oldest first; the last is the one being written
  int fd_ = -1;
  std::uint64_t rows_written_ = 0;
  int next_number_ = 0;
  std::chrono::steady_clock::time_point file_opened_;
  std::thread thread_;
};

}  // namespace pvcap
