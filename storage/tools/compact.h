#pragma once
// `pvcap compact SESSION`: re-encodes a finished session's raw video segments to a denser lossless
// codec (docs/store.md, "Compacting a session"). The live store uses a fast codec (ffvhuff or
// MagicYUV: the only ones that keep up with four cameras beside the capture); after the session,
// x264 lossless with inter prediction keeps the same mosaics in fewer bytes.
//
// Nothing is lost on the way, whatever stops it:
//   - every frame of the old segment is checked against its capture checksum as it is read, and
//     every frame of the new one, decoded again after it is on disk, against the old one's (bit for
//     bit, same timestamp, same count) before anything refers to it;
//   - the new segment is written under a temporary name, fsynced, renamed, and the folder fsynced;
//     only then does one index transaction (synchronous) point the segment's row at it; only after
//     that commit is the old file removed. A kill or a power cut at any moment leaves the index
//     naming a complete file, old or new; the next run removes what an interrupted one left.
// A session being recorded or recovered (its recording.lock held) is refused; one not closed
// cleanly needs `pvcap recover` first. Colour (lossy) segments have nothing to compact.
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"

namespace pvcap {

struct CompactOptions {
  // What the compacted store is for (docs/store.md, "Compacting a session"):
  //   - "libx264" (qp 0, a GOP; `--for archive`): the fewest bytes; a shuffled read decodes from the
  //     last key frame, whole pictures;
  //   - "ffvhuff" (tables fitted to the segment, left prediction, every frame alone, in tiles; `--for training`):
  //     reads shuffled crops as fast as the live store, for fewer bytes than it;
  //   - "ffv1" (intra only).
  // A mosaic of more than 8 bits takes ffv1 when libx264 is asked for (x264 keeps at most 10 bits).
  std::string codec = "libx264";
  std::string preset = "veryfast";  // libx264's; the densest of its fast presets on noisy mosaics
  int gop_frames = 15;              // frames between key frames: a random read decodes at most this many
  int threads = 2;
  // Called as the work goes: the segment, its frames done and in all, the whole session's frames done
  // and in all.
  std::function<void(const std::string& segment, std::int64_t done, std::int64_t total, std::int64_t session_done,
                     std::int64_t session_total)>
      progress;
  // Set (e.g. by Ctrl-C) to stop between frames: the segment in hand is left as it was.
  const std::atomic<bool>* stop = nullptr;
  // For tests: called after each step of a segment's replacement ("written", "renamed",
  // "committed"); returning false ends the run right there, as a kill would (nothing tidied up).
  std::function<bool(std::string_view step)> after_step;
};

struct CompactReport {
  std::vector<std::string> done;  // what was changed or found, in order
  std::int64_t segments_compacted = 0;
  std::int64_t segments_kept = 0;  // not smaller in the new codec, already in it, colour, or not closed
  std::int64_t frames = 0;         // frames re-encoded and checked
  std::uint64_t bytes_before = 0, bytes_after = 0;  // of the segments compacted
  // Shuffled 480x384 crops (with their demosaicing margin) read per second of one core from the first
  // segment compacted, before and after (0: nothing compacted).
  double crops_per_s_before = 0, crops_per_s_after = 0;
  double elapsed_s = 0;
  bool stopped = false;  // the stop flag ended it early
};

// The session folder's segments compacted one after another. An Error names the session and what
// failed (a damaged frame, a full disk, a refused lock); segments already compacted stay compacted.
Result<CompactReport> compact_session(const std::filesystem::path& dir, const CompactOptions& options = {});

// What `pvcap compact` prints of a session compacted: what was done, the size gained and the read
// speed of the result, and how to go on when it was stopped.
std::string describe_compact_report(const std::filesystem::path& dir, const CompactReport& r);

}  // namespace pvcap
