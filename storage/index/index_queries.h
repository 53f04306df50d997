#pragma once
// What the rooms beside the index ask of session.db, each as a named query, so that SQL is spoken in
// this room only (docs/architecture.md): verify's checks (storage/tools/verify.h), compact's
// segments (storage/tools/compact.h) and what recover reads and repairs
// (storage/writer/recover.h). The recording's own writes are SessionIndex's (session_index.h), a
// finished session's reads SessionReader's (session_reader.h).
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "storage/index/database.h"
#include "storage/index/records.h"

namespace pvcap {

// The session row: when it started and how it ended (no end: the recording was cut).
struct SessionRow {
  std::int64_t started_host_ns = 0;
  std::optional<std::int64_t> ended_host_ns;
  std::string end_reason;
  std::string rig_config, rig_path;  // the rig's text as recorded, and where it was read from
};
std::optional<SessionRow> session_row(sqlite::Database& db);

// SQLite's own check of the file: "ok", or what is damaged.
std::string index_quick_check(sqlite::Database& db);

// Writes the write-ahead log into the database file and empties it: a folder that is then copied or
// read elsewhere holds its whole index in session.db.
void checkpoint_index(sqlite::Database& db);

// A video file the index names, with its camera's name (empty when the index lost its device row) and
// its number of kept frames.
struct IndexedVideo {
  std::int64_t id = 0, device_id = 0;
  std::string path, camera, state, codec, layout;
  std::optional<std::string> bayer_format;
  int width = 0, height = 0, segment = 0, bit_depth = 8;
  std::int64_t kept_frames = 0;
};
std::vector<IndexedVideo> indexed_videos(sqlite::Database& db);  // in the order of their ids
std::vector<IndexedVideo> indexed_videos_in_state(sqlite::Database& db, const std::string& state);
std::optional<IndexedVideo> last_segment_of(sqlite::Database& db, std::int64_t device_id);
std::int64_t next_video_file_id(sqlite::Database& db);
void rename_video_file(sqlite::Database& db, std::int64_t id, const std::string& path, const std::string& codec);

// A frame a video holds, as its row has it, in video order.
struct KeptFrameRow {
  std::optional<std::int64_t> video_index;  // none: a row the index failed to place
  std::int64_t host_ns = 0;
  std::optional<std::int64_t> video_pts_ms;
  std::optional<std::uint32_t> checksum;
  std::int64_t connection = 0, sequence = 0;
};
std::vector<KeptFrameRow> kept_frames_of_video(sqlite::Database& db, std::int64_t video_file_id);

// Whether the frame has a row, and whether that row says it is in a video.
std::optional<bool> frame_kept(sqlite::Database& db, std::int64_t device_id, std::int64_t connection,
                               std::int64_t sequence);
// The frame's row made to say where a video holds it (`row`'s video fields); false when it has no row.
bool place_frame_in_video(sqlite::Database& db, const FrameRecord& row);

// A stored pressure frame, as verify reads it back.
struct StoredPressureRow {
  std::vector<std::uint8_t> payload;
  int grid_cols = 0, grid_rows = 0, grid_xscale = 0, grid_yscale = 0;
  std::int64_t sequence = 0, base = 0, connection = 0;
  std::optional<std::vector<std::uint8_t>> counts;
  std::optional<std::uint32_t> checksum;
};
void for_each_stored_pressure_frame(sqlite::Database& db, const std::function<void(const StoredPressureRow&)>& visit);

// What the index counts of its samples and of the losses recorded during capture.
struct IndexTallies {
  std::int64_t samples = 0;
  std::int64_t sample_frames_not_in_video = 0;  // sample frames whose row is not kept in a video
  std::int64_t samples_without_pressure = 0;
  bool has_sensel = false;
  std::int64_t frames_dropped = 0;     // the drops table: never arrived
  std::int64_t frames_incomplete = 0;  // arrived with a status other than good
  std::map<std::string, std::int64_t> frames_by_reason;
};
IndexTallies index_tallies(sqlite::Database& db);

// The time of the last thing stored (frame, pressure frame, or the start): where a cut session ends.
std::int64_t last_stored_host_ns(sqlite::Database& db);

}  // namespace pvcap
