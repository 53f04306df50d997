#include "storage/index/schema.h"

#include <chrono>
#include <limits>

#include <fmt/format.h>

#include "codec/sensel_frame.h"
#include "storage/index/pressure_blob.h"

namespace pvcap {

namespace {
// Version 1, as pvcap 0.1 created it. A new index is this plus every step below, so a fresh
// store and an upgraded one are the same tables, column for column (docs/store.md explains them).
constexpr const char* kV1 = R"sql(
CREATE TABLE session (
  id INTEGER PRIMARY KEY,
  started_wall_ns INTEGER NOT NULL,
  started_host_ns INTEGER NOT NULL,
  ended_host_ns INTEGER,
  end_reason TEXT,
  pvcap_version TEXT NOT NULL,
  rig_name TEXT NOT NULL,
  rig_path TEXT NOT NULL,
  rig_config TEXT NOT NULL,
  simulated INTEGER NOT NULL
);
CREATE TABLE devices (
  id INTEGER PRIMARY KEY,
  kind TEXT NOT NULL,
  name TEXT NOT NULL UNIQUE,
  vendor TEXT, model TEXT, serial TEXT, address TEXT, firmware TEXT,
  settings_json TEXT NOT NULL
);
CREATE TABLE video_files (
  id INTEGER PRIMARY KEY,
  device_id INTEGER NOT NULL REFERENCES devices(id),
  path TEXT NOT NULL UNIQUE,
  codec TEXT NOT NULL,
  pixel_format TEXT NOT NULL,
  width INTEGER NOT NULL,
  height INTEGER NOT NULL
);
CREATE TABLE frames (
  device_id INTEGER NOT NULL REFERENCES devices(id),
  connection INTEGER NOT NULL,
  sequence INTEGER NOT NULL,
  frame_id INTEGER NOT NULL,
  device_ns INTEGER NOT NULL,
  host_ns INTEGER NOT NULL,
  aravis_system_ns INTEGER NOT NULL,
  status TEXT NOT NULL,
  kept INTEGER NOT NULL,
  reason TEXT,
  video_file_id INTEGER REFERENCES video_files(id),
  video_index INTEGER
);
CREATE INDEX frames_by_time ON frames(device_id, host_ns);
CREATE INDEX frames_by_video ON frames(video_file_id, video_index);
CREATE TABLE pressure_frames (
  device_id INTEGER NOT NULL REFERENCES devices(id),
  connection INTEGER NOT NULL,
  sequence INTEGER NOT NULL,
  lost_before INTEGER NOT NULL,
  device_ns INTEGER NOT NULL,
  host_ns INTEGER NOT NULL,
  host_wait_ns INTEGER NOT NULL,
  grid_cols INTEGER NOT NULL, grid_rows INTEGER NOT NULL, grid_xscale INTEGER NOT NULL, grid_yscale INTEGER NOT NULL,
  payload BLOB NOT NULL
);
CREATE INDEX pressure_by_time ON pressure_frames(device_id, host_ns);
CREATE TABLE drops (
  device_id INTEGER NOT NULL REFERENCES devices(id),
  connection INTEGER NOT NULL,
  first_sequence INTEGER NOT NULL,
  count INTEGER NOT NULL,
  reason TEXT NOT NULL,
  host_ns INTEGER NOT NULL
);
CREATE TABLE events (
  host_ns INTEGER NOT NULL,
  kind TEXT NOT NULL,
  device_id INTEGER REFERENCES devices(id),
  message TEXT NOT NULL
);
CREATE TABLE stream_stats (
  device_id INTEGER NOT NULL REFERENCES devices(id),
  completed INTEGER NOT NULL, failures INTEGER NOT NULL, underruns INTEGER NOT NULL,
  resent_packets INTEGER NOT NULL, missing_packets INTEGER NOT NULL, queue_overflows INTEGER NOT NULL
);
)sql";

// 1 -> 2: the timeline's mapped times and tables.
constexpr const char* kTo2 = R"sql(
ALTER TABLE frames ADD COLUMN mapped_ns INTEGER;
ALTER TABLE pressure_frames ADD COLUMN mapped_ns INTEGER;
CREATE TABLE samples (
  id INTEGER PRIMARY KEY,
  tick INTEGER NOT NULL,
  tick_ns INTEGER NOT NULL,
  t_ns INTEGER NOT NULL,
  span_ns INTEGER NOT NULL,
  cameras INTEGER NOT NULL,
  pressure_device_id INTEGER REFERENCES devices(id),
  pressure_connection INTEGER,
  pressure_sequence INTEGER,
  pressure_offset_ns INTEGER,
  before_sequence INTEGER,
  before_offset_ns INTEGER,
  after_sequence INTEGER,
  after_offset_ns INTEGER
);
CREATE TABLE sample_frames (
  sample_id INTEGER NOT NULL REFERENCES samples(id),
  device_id INTEGER NOT NULL REFERENCES devices(id),
  connection INTEGER NOT NULL,
  sequence INTEGER NOT NULL,
  offset_ns INTEGER NOT NULL
);
CREATE INDEX sample_frames_by_sample ON sample_frames(sample_id);
CREATE INDEX frames_by_sequence ON frames(device_id, connection, sequence);
CREATE INDEX pressure_by_sequence ON pressure_frames(device_id, connection, sequence);
CREATE TABLE clock_models (
  device_id INTEGER NOT NULL REFERENCES devices(id),
  host_ns INTEGER NOT NULL,
  segment INTEGER NOT NULL,
  x0_device_ns INTEGER NOT NULL,
  offset_ns REAL NOT NULL,
  skew REAL NOT NULL,
  latency_ns INTEGER NOT NULL,
  source TEXT NOT NULL,
  pairs INTEGER NOT NULL,
  envelope_points INTEGER NOT NULL,
  residual_p50_ns INTEGER NOT NULL,
  residual_p99_ns INTEGER NOT NULL
);
CREATE TABLE timeline_counts (
  what TEXT NOT NULL,
  count INTEGER NOT NULL
);
)sql";

// 2 -> 3: session conditions, calibrations, protocol, notes, segments, portable pressure counts
// (filled below from the device payloads).
constexpr const char* kTo3 = R"sql(
ALTER TABLE frames ADD COLUMN video_pts_ms INTEGER;
ALTER TABLE video_files ADD COLUMN segment INTEGER NOT NULL DEFAULT 0;
ALTER TABLE video_files ADD COLUMN state TEXT NOT NULL DEFAULT 'closed';
ALTER TABLE video_files ADD COLUMN frames INTEGER;
ALTER TABLE pressure_frames ADD COLUMN base INTEGER;
ALTER TABLE pressure_frames ADD COLUMN counts BLOB;
CREATE TABLE participant (
  pseudonym TEXT NOT NULL,
  skin_tone TEXT NOT NULL,
  hand_order TEXT NOT NULL
);
CREATE TABLE conditions (
  lighting TEXT NOT NULL,
  sensor_overlay TEXT NOT NULL
);
CREATE TABLE calibrations (
  id INTEGER PRIMARY KEY,
  device_id INTEGER NOT NULL REFERENCES devices(id),
  created_wall_ns INTEGER NOT NULL,
  method TEXT NOT NULL,
  homography TEXT NOT NULL,
  rms_px REAL,
  rms_mm REAL,
  details_json TEXT NOT NULL DEFAULT '{}'
);
CREATE TABLE protocol_events (
  id INTEGER PRIMARY KEY,
  host_ns INTEGER NOT NULL,
  kind TEXT NOT NULL,
  step INTEGER,
  action TEXT,
  hand TEXT,
  force TEXT,
  repetition INTEGER,
  detail TEXT
);
CREATE INDEX protocol_events_by_time ON protocol_events(host_ns);
CREATE TABLE operator_notes (
  host_ns INTEGER NOT NULL,
  text TEXT NOT NULL
);
CREATE INDEX samples_by_time ON samples(t_ns);
)sql";

// 3 -> 4: raw videos (the sensor's Bayer mosaic, stored losslessly) say so in their row.
constexpr const char* kTo4 = R"sql(
ALTER TABLE video_files ADD COLUMN layout TEXT NOT NULL DEFAULT 'bgr';
ALTER TABLE video_files ADD COLUMN bayer_format TEXT;
ALTER TABLE video_files ADD COLUMN bit_depth INTEGER;
)sql";

// 4 -> 5: each stored frame's checksum, taken at capture (storage/video/frame_checksum.h). An older
// store's frames have none (NULL): they were not taken when those frames were captured.
constexpr const char* kTo5 = R"sql(
ALTER TABLE frames ADD COLUMN checksum INTEGER;
ALTER TABLE pressure_frames ADD COLUMN checksum INTEGER;
)sql";

// 5 -> 6: each frame's own state from its chunk data (capture/aravis_chunks.h); NULL where the
// camera sent none, as in every older store.
constexpr const char* kTo6 = R"sql(
ALTER TABLE frames ADD COLUMN chunk_frame_counter INTEGER;
ALTER TABLE frames ADD COLUMN chunk_timestamp INTEGER;
ALTER TABLE frames ADD COLUMN chunk_exposure_us REAL;
ALTER TABLE frames ADD COLUMN chunk_gain REAL;
)sql";

// 6 -> 7: each frame's line levels from its chunk data (ChunkLineStatusAll: the lights a camera
// drives, per frame); NULL where the camera sent none, as in every older store.
constexpr const char* kTo7 = R"sql(
ALTER TABLE frames ADD COLUMN chunk_line_status INTEGER;
)sql";

// Decodes every stored device payload once and stores its counts in the portable form. Read in
// pages by rowid, each page before its updates: rows are never changed under a running SELECT.
void fill_pressure_counts(sqlite::Database& db, const std::function<void(const std::string&)>& progress) {
  auto update = db.prepare("UPDATE pressure_frames SET base = ?, counts = ? WHERE rowid = ?");
  std::int64_t after = std::numeric_limits<std::int64_t>::min();
  std::int64_t total = 0, done = 0;
  {
    auto q = db.prepare("SELECT count(*) FROM pressure_frames");
    if (q.step()) total = q.column_int(0);
  }
  auto last_report = std::chrono::steady_clock::now();
  auto report = [&](bool finished) {
    const auto now = std::chrono::steady_clock::now();
    if (!progress || total == 0 || (!finished && now - last_report < std::chrono::seconds(1))) return;
    last_report = now;
    progress(fmt::format("raw pressure counts: {} of {} frames", done, total));
  };
  for (;;) {
    struct Row {
      std::int64_t rowid;
      sensel::Grid grid;
      std::vector<std::uint8_t> payload;
    };
    std::vector<Row> page;
    {
      auto q = db.prepare(
          "SELECT rowid, grid_cols, grid_rows, grid_xscale, grid_yscale, payload FROM pressure_frames WHERE rowid > ? "
          "ORDER BY rowid LIMIT 4096");
      q.bind_all(after);
      while (q.step())
        page.push_back({q.column_int(0),
                        {int(q.column_int(1)), int(q.column_int(2)), int(q.column_int(3)), int(q.column_int(4))},
                        q.column_blob(5)});
    }
    if (page.empty()) return report(true);
    for (const auto& row : page) {
      ++done;
      auto frame = sensel::parse_frame(row.payload, row.grid);
      if (!frame || !frame.value().pressure) continue;  // stays NULL: verify reports it
      const auto& p = *frame.value().pressure;
      update.bind_all(std::int64_t(p.base), compress_counts(p.counts), row.rowid).run();
    }
    after = page.back().rowid;
    report(false);
  }
}

bool is_session_index(sqlite::Database& db) {
  auto q = db.prepare(
      "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name IN ('session', 'frames', 'devices')");
  return q.step() && q.column_int(0) == 3;
}

// Upgrades from `version` to version + 1; the caller holds the transaction.
void apply_step(sqlite::Database& db, int version, const std::function<void(const std::string&)>& progress) {
  if (version == 1) db.exec(kTo2);
  if (version == 2) {
    db.exec(kTo3);
    fill_pressure_counts(db, progress);
  }
  if (version == 3) db.exec(kTo4);
  if (version == 4) db.exec(kTo5);
  if (version == 5) db.exec(kTo6);
  if (version == 6) db.exec(kTo7);
  db.set_user_version(version + 1);
}
}  // namespace

void create_schema(sqlite::Database& db, int version) {
  sqlite::Transaction tx(db);
  db.exec(kV1);
  db.set_user_version(1);
  for (int v = 1; v < version; ++v) apply_step(db, v, nullptr);
  tx.commit();
}

std::vector<int> migrate_schema(sqlite::Database& db, const std::function<void(const std::string&)>& progress) {
  const int from = db.user_version();
  if (from == kSchemaVersion) return {};
  if (from > kSchemaVersion)
    throw sqlite::SqliteError(0, fmt::format("{}: schema version {} is newer than this pvcap's {}: update pvcap",
                                             db.path().string(), from, kSchemaVersion));
  if (from < 1 || !is_session_index(db))
    throw sqlite::SqliteError(0, fmt::format("{}: not a pvcap session index", db.path().string()));
  std::vector<int> passed;
  for (int v = from; v < kSchemaVersion; ++v) {
    sqlite::Transaction tx(db);
    if (progress) progress(fmt::format("upgrading the index from version {} to {}", v, v + 1));
    apply_step(db, v, progress);
    tx.commit();
    passed.push_back(v + 1);
  }
  return passed;
}

std::filesystem::path back_up_before_migration(const std::filesystem::path& db_path, int version) {
  namespace fs = std::filesystem;
  const fs::path copy = db_path.string() + fmt::format(".v{}.bak", version);
  std::error_code ec;
  for (const char* suffix : {"", "-wal"}) {
    const fs::path from = db_path.string() + suffix;
    if (!fs::exists(from)) continue;
    fs::copy_file(from, copy.string() + suffix, fs::copy_options::overwrite_existing, ec);
    if (ec)
      throw sqlite::SqliteError(
          0, fmt::format("{}: cannot back up the index before upgrading it: {}", copy.string() + suffix, ec.message()));
  }
  return copy;
}

}  // namespace pvcap
