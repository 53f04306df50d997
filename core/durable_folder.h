#pragma once
// The session's durability horizon (docs/store.md, "What a power cut can lose"): while recording,
// every file of the session folder that changed (video segments, spill files, the index and its
// WAL) and the folder entries themselves reach stable storage once a second. The writes go to the
// kernel as they happen (FFmpeg flushes each packet, the spill writes each frame, SQLite each
// commit); what this adds is the fsync that makes them survive a power cut, from a thread that is
// not a device thread. An fsync that fails (EIO: the disk lost written data) is an error naming
// the file: the session stops, as for any failed write.
#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <ctime>
#include <filesystem>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"

namespace pvcap {

// fsyncs one file or folder now: a file that is final (a finished segment), a folder whose entries
// just changed. The failure names the path and the error.
Status sync_to_disk(const std::filesystem::path& path);

// A file written whole or not at all: `bytes` go to a temporary name beside `file` and are renamed
// over it, so a reader or a resumed run never sees half of it. Synced also puts the file and its
// folder's entry on the disk before returning (a power cut keeps it: a dataset's own files);
// Renamed leaves that to the kernel (an export's thousands of JPEGs, which a resumed export checks).
enum class Durability { Renamed, Synced };
Status write_file_atomically(const std::filesystem::path& file, std::string_view bytes, Durability durability);

class DurableFolder {
 public:
  // `dir` and its `subfolders` (created later is fine: they are synced once they exist).
  DurableFolder(std::filesystem::path dir, std::vector<std::string> subfolders);
  DurableFolder(const DurableFolder&) = delete;
  DurableFolder& operator=(const DurableFolder&) = delete;

  // fsyncs every regular file whose size or modification time changed since the last call, and
  // each folder whose entries changed. The first failure, naming the file and the error.
  Status sync_changed();
  // Starts the write-back of every file that grew since the last call, without waiting for it
  // (sync_file_range): called between the fsyncs, it spreads the writing over the second so the
  // fsync finds little left to write and the disk never takes a second's writes at once. On a
  // congested disk the call itself can block (169 ms beside a test suite), so it runs on a
  // thread of its own, never the rounds': it shares no state with sync_changed().
  void start_writeback();

  struct Counts {
    std::uint64_t rounds = 0, file_syncs = 0, folder_syncs = 0;
    double slowest_round_ms = 0, last_round_ms = 0;
    // From the previous round's start (its listing) to this one's end: how long a write could wait
    // unsynced (one made just after the previous round listed its file is synced by this round).
    double last_gap_ms = 0;
  };
  const Counts& counts() const { return counts_; }

 private:
  struct Tracked {
    off_t size = -1;
    timespec mtime{};
  };
  struct Changed {
    std::filesystem::path path;
    Tracked seen;  // its size and time when listed
    Status status;
    bool synced = false;
  };
  Status list_folder(const std::filesystem::path& folder, std::vector<Changed>& changed, bool& entries_changed);
  static void sync_files(std::vector<Changed>& changed);

  std::filesystem::path dir_;
  std::vector<std::filesystem::path> folders_;
  // What each file was at its last fsync. No descriptor is kept between rounds: an open one would
  // keep a removed file's space (the space reserve freed on a full disk, a drained spill file). An
  // fsync on a fresh descriptor still reports a write-back error nobody has seen (Linux errseq).
  std::map<std::filesystem::path, Tracked> files_;
  std::map<std::filesystem::path, std::size_t> entries_;  // each folder's entry count at the last round
  Counts counts_;
  std::chrono::steady_clock::time_point last_round_start_{};
  std::map<std::filesystem::path, off_t> written_back_;  // start_writeback's own: each file's size when last started
};

}  // namespace pvcap
