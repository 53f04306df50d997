#include "storage/index/index_queries.h"

namespace pvcap {

namespace {
std::optional<std::int64_t> query_int_or_null(const sqlite::Statement& q, int col) {
  return q.column_null(col) ? std::nullopt : std::optional(q.column_int(col));
}
std::string query_text_or_empty(const sqlite::Statement& q, int col) {
  return q.column_null(col) ? "" : q.column_text(col);
}

constexpr const char* kIndexedVideoColumns =
    "SELECT v.id, v.device_id, v.path, d.name, v.state, v.codec, v.layout, v.bayer_format, v.width, v.height, "
    "v.segment, coalesce(v.bit_depth, 8), (SELECT count(*) FROM frames f WHERE f.video_file_id = v.id AND f.kept = 1) "
    "FROM video_files v LEFT JOIN devices d ON d.id = v.device_id ";

IndexedVideo indexed_video(const sqlite::Statement& q) {
  IndexedVideo v;
  v.id = q.column_int(0);
  v.device_id = q.column_int(1);
  v.path = q.column_text(2);
  v.camera = query_text_or_empty(q, 3);
  v.state = query_text_or_empty(q, 4);
  v.codec = query_text_or_empty(q, 5);
  v.layout = query_text_or_empty(q, 6);
  if (!q.column_null(7)) v.bayer_format = q.column_text(7);
  v.width = int(q.column_int(8));
  v.height = int(q.column_int(9));
  v.segment = int(q.column_int(10));
  v.bit_depth = int(q.column_int(11));
  v.kept_frames = q.column_int(12);
  return v;
}
}  // namespace

std::optional<SessionRow> session_row(sqlite::Database& db) {
  auto q = db.prepare("SELECT started_host_ns, ended_host_ns, end_reason, rig_config, rig_path FROM session");
  if (!q.step()) return std::nullopt;
  return SessionRow{q.column_int(0), query_int_or_null(q, 1), query_text_or_empty(q, 2), query_text_or_empty(q, 3),
                    query_text_or_empty(q, 4)};
}

std::string index_quick_check(sqlite::Database& db) {
  auto q = db.prepare("PRAGMA quick_check");
  return q.step() ? q.column_text(0) : "ok";
}

void checkpoint_index(sqlite::Database& db) { db.exec("PRAGMA wal_checkpoint(TRUNCATE)"); }

std::vector<IndexedVideo> indexed_videos(sqlite::Database& db) {
  std::vector<IndexedVideo> out;
  auto q = db.prepare(std::string(kIndexedVideoColumns) + "ORDER BY v.id");
  while (q.step()) out.push_back(indexed_video(q));
  return out;
}

std::vector<IndexedVideo> indexed_videos_in_state(sqlite::Database& db, const std::string& state) {
  std::vector<IndexedVideo> out;
  auto q = db.prepare(std::string(kIndexedVideoColumns) + "WHERE v.state = ? ORDER BY v.id");
  q.bind_all(state);
  while (q.step()) out.push_back(indexed_video(q));
  return out;
}

std::optional<IndexedVideo> last_segment_of(sqlite::Database& db, std::int64_t device_id) {
  auto q = db.prepare(std::string(kIndexedVideoColumns) + "WHERE v.device_id = ? ORDER BY v.segment DESC LIMIT 1");
  q.bind_all(device_id);
  if (!q.step()) return std::nullopt;
  return indexed_video(q);
}

std::int64_t next_video_file_id(sqlite::Database& db) {
  auto q = db.prepare("SELECT coalesce(max(id), 0) + 1 FROM video_files");
  q.step();
  return q.column_int(0);
}

void rename_video_file(sqlite::Database& db, std::int64_t id, const std::string& path, const std::string& codec) {
  db.prepare("UPDATE video_files SET path = ?, codec = ? WHERE id = ?").bind_all(path, codec, id).run();
}

std::vector<KeptFrameRow> kept_frames_of_video(sqlite::Database& db, std::int64_t video_file_id) {
  auto q = db.prepare(
      "SELECT video_index, host_ns, video_pts_ms, checksum, connection, sequence FROM frames WHERE video_file_id = ? "
      "AND kept = 1 ORDER BY video_index");
  q.bind_all(video_file_id);
  std::vector<KeptFrameRow> out;
  while (q.step()) {
    KeptFrameRow k;
    k.video_index = query_int_or_null(q, 0);
    k.host_ns = q.column_int(1);
    k.video_pts_ms = query_int_or_null(q, 2);
    if (!q.column_null(3)) k.checksum = std::uint32_t(q.column_int(3));
    k.connection = q.column_int(4);
    k.sequence = q.column_int(5);
    out.push_back(k);
  }
  return out;
}

std::optional<bool> frame_kept(sqlite::Database& db, std::int64_t device_id, std::int64_t connection,
                               std::int64_t sequence) {
  auto q = db.prepare("SELECT kept FROM frames WHERE device_id = ? AND connection = ? AND sequence = ?");
  q.bind_all(device_id, connection, sequence);
  if (!q.step()) return std::nullopt;
  return q.column_int(0) == 1;
}

bool place_frame_in_video(sqlite::Database& db, const FrameRecord& row) {
  db.prepare(
        "UPDATE frames SET kept = 1, reason = NULL, video_file_id = ?, video_index = ?, video_pts_ms = ? WHERE "
        "device_id = ? AND connection = ? AND sequence = ?")
      .bind_all(row.video_file_id, row.video_index, row.video_pts_ms, row.device_id, std::int64_t(row.connection),
                std::int64_t(row.sequence))
      .run();
  return db.changes() > 0;
}

void for_each_stored_pressure_frame(sqlite::Database& db, const std::function<void(const StoredPressureRow&)>& visit) {
  auto q = db.prepare(
      "SELECT payload, grid_cols, grid_rows, grid_xscale, grid_yscale, sequence, base, counts, checksum, connection "
      "FROM pressure_frames");
  while (q.step()) {
    StoredPressureRow r;
    r.payload = q.column_blob(0);
    r.grid_cols = int(q.column_int(1));
    r.grid_rows = int(q.column_int(2));
    r.grid_xscale = int(q.column_int(3));
    r.grid_yscale = int(q.column_int(4));
    r.sequence = q.column_int(5);
    r.base = q.column_int(6);
    if (!q.column_null(7)) r.counts = q.column_blob(7);
    if (!q.column_null(8)) r.checksum = std::uint32_t(q.column_int(8));
    r.connection = q.column_int(9);
    visit(r);
  }
}

IndexTallies index_tallies(sqlite::Database& db) {
  auto scalar = [&](const char* sql) {
    auto q = db.prepare(sql);
    return q.step() && !q.column_null(0) ? q.column_int(0) : std::int64_t(0);
  };
  IndexTallies t;
  t.samples = scalar("SELECT count(*) FROM samples");
  t.sample_frames_not_in_video = scalar(
      "SELECT count(*) FROM sample_frames sf LEFT JOIN frames f USING (device_id, connection, sequence) "
      "WHERE f.kept IS NOT 1 OR f.video_index IS NULL");
  t.samples_without_pressure = scalar("SELECT count(*) FROM samples WHERE pressure_sequence IS NULL");
  t.has_sensel = scalar("SELECT count(*) FROM devices WHERE kind = 'sensel'") > 0;
  t.frames_dropped = scalar("SELECT sum(count) FROM drops");
  t.frames_incomplete = scalar("SELECT count(*) FROM frames WHERE status <> 'good'");
  auto q = db.prepare("SELECT reason, count(*) FROM frames WHERE reason IS NOT NULL GROUP BY reason");
  while (q.step()) t.frames_by_reason[q.column_text(0)] = q.column_int(1);
  return t;
}

std::int64_t last_stored_host_ns(sqlite::Database& db) {
  auto q = db.prepare(
      "SELECT max(t) FROM (SELECT max(host_ns) AS t FROM frames UNION ALL SELECT max(host_ns) FROM pressure_frames "
      "UNION ALL SELECT started_host_ns FROM session)");
  return q.step() && !q.column_null(0) ? q.column_int(0) : 0;
}

}  // namespace pvcap
