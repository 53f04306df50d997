#pragma once
// Making the index agree with what a video file really holds, after a crash or a
// failed write: count the complete frames on disk, mark index rows beyond them as
// not in the video (never deleting a row), and copy a cut file's readable frames
// into a properly finished one (the cut original stays beside it).
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "core/result.h"
#include "storage/index/session_index.h"

namespace pvcap {

// Complete frames (packets) in a video file, read without decoding; stops at the first
// damaged or cut packet. Error when the file cannot be opened as a video at all.
Result<std::int64_t> count_video_frames(const std::filesystem::path& path);

struct ReconcileResult {
  std::string path;
  std::int64_t frames_in_file = 0;
  std::int64_t rows_marked_lost = 0;  // rows that named a position past the file's end
};
// For video file `id` of the index: rows whose position is past what the file holds get
// kept = 0 and `reason`; the file's row gets `state` and its frame count. Throws SqliteError.
ReconcileResult reconcile_video_file(SessionIndex& index, const std::filesystem::path& session_dir, std::int64_t id,
                                     std::string_view reason, std::string_view state);

// The leading frames of video file `id` that are the frames its index rows name (kept rows, in video
// order): each at its row's timestamp and, for a raw video whose row has a capture checksum, with
// the pixels that checksum was taken of. A power cut can leave a segment's tail with writes missing
// or torn: the demuxer then skips to a later cluster, or reads a frame whose bytes are partly
// another's; counting stops at the first frame that is not its row's. Error when the file cannot be
// opened as a video at all. Throws SqliteError.
Result<std::int64_t> count_frames_matching_index(SessionIndex& index, const std::filesystem::path& session_dir,
                                                 std::int64_t id, std::int64_t started_host_ns);

// Copies the first `frames` packets of `from` into a new, finished Matroska file `to`
// (cues, duration) without re-encoding.
Status remux_prefix(const std::filesystem::path& from, const std::filesystem::path& to, std::int64_t frames);

}  // namespace pvcap
