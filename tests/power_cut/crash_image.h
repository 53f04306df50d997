// Builds a folder as a power cut would have left it, from a trace of the writes, syncs and name
// changes made in it (tests/power_cut/io_trace.c). The model is POSIX's, as ALICE and CrashMonkey
// use it, not a kind file system's:
// - a file's bytes are on the disk as they were at its last fsync (or fdatasync); each write or
//   truncation after it, up to the cut, is kept, dropped or torn (only its first sectors reached
//   the disk), at random and independently of the others;
// - a name (a file created, renamed or removed, a folder made) is on the disk once the folder that
//   holds it was fsynced; of the later changes in one folder, a random prefix (the journal keeps
//   them in order) reached the disk, and a change whose folder is gone is gone with it.
// Test instrument: nothing of pvcap links it.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace pvcap::power_cut {

struct TraceOp {
  std::uint32_t op = 0;  // trace_op (tests/power_cut/trace_format.h)
  std::uint32_t flags = 0;
  std::string path, path2;
  std::int64_t t_ns = 0, offset = 0, length = 0, data_pos = -1;
};

struct Trace {
  std::filesystem::path dir;  // holds `ops` and `data`
  std::vector<TraceOp> ops;
};

// Reads DIR/ops; throws std::runtime_error naming the file if it is not a whole trace.
Trace read_trace(const std::filesystem::path& dir);

struct CrashImageCounts {
  std::size_t files = 0, folders = 0;
  std::size_t writes_after_sync = 0, kept = 0, dropped = 0, torn = 0;
  std::size_t names_after_sync = 0, names_kept = 0;
};

// Writes, under `out` (which must not exist), the folder `root` as a power cut just before
// trace.ops[cut] (so ops [0, cut) had been made) would have left it; what each unsynced change
// became is drawn from `seed`. `root` existed, empty, before the trace began.
CrashImageCounts build_crash_image(const Trace& trace, const std::filesystem::path& root, std::size_t cut,
                                   std::uint64_t seed, const std::filesystem::path& out);

}  // namespace pvcap::power_cut
