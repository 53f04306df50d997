#pragma once
// The session index's schema and its migrations. PRAGMA user_version is the schema
// version; docs/store.md documents every table of the current one. A store written
// by an older pvcap is upgraded step by step (1 -> 2 -> ... -> 7), each step in its own
// transaction, so an interrupted upgrade leaves a consistent older version behind.
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "storage/index/database.h"

namespace pvcap {

// 1: frames, pressure frames, drops, events (pvcap 0.1)
// 2: mapped times, 15 Hz samples, clock models, timeline counts
// 3: participant, conditions, calibrations, protocol events, operator notes, pressure counts
//    (zlib), video segments with their state
// 4: raw videos: each video file's layout (bgr or bayer_planes), Bayer pattern and bit depth
// 5: checksums: each stored frame's CRC-32, taken at capture (frames.checksum, pressure_frames.checksum)
// 6: each frame's own state from its chunk data (frames.chunk_frame_counter, chunk_timestamp,
//    chunk_exposure_us, chunk_gain)
// 7: each frame's line levels from its chunk data (frames.chunk_line_status: the lights, per frame)
inline constexpr int kSchemaVersion = 7;
// The oldest version SessionReader reads as it is (3 differs from 4 only by colour-only videos).
inline constexpr int kOldestReadableSchemaVersion = 3;

// Creates the schema of `version` (the current one unless a test asks for an older store) in an
// empty database: version 1, then each upgrade step, in one transaction.
void create_schema(sqlite::Database& db, int version = kSchemaVersion);

// Upgrades an older index to kSchemaVersion; returns the versions it passed through
// (empty when already current). Throws SqliteError naming the database on failure,
// and for an index newer than this pvcap or one that is not a session index.
// `progress` hears of each step and of how far the long one (decoding every pressure frame for its
// raw counts) has come: at most once a second, and when it is done.
std::vector<int> migrate_schema(sqlite::Database& db,
                                const std::function<void(const std::string&)>& progress = nullptr);

// Copies session.db (with its -wal, if any) to `<db>.v<N>.bak` before an upgrade, so
// an upgrade never costs the original. Returns the copy's path.
std::filesystem::path back_up_before_migration(const std::filesystem::path& db_path, int version);

}  // namespace pvcap
