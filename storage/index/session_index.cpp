#include "storage/index/session_index.h"

#include <fmt/format.h>

#include "storage/index/pressure_blob.h"
#include "sync/clock_fit.h"

namespace pvcap {

SessionIndex SessionIndex::create(const std::filesystem::path& path) {
  if (std::filesystem::exists(path)) throw sqlite::SqliteError(0, fmt::format("{}: already exists", path.string()));
  auto db = std::make_unique<sqlite::Database>(path, sqlite::Database::Mode::Create);
  db->apply_resilient_pragmas();
  create_schema(*db);
  return SessionIndex(std::move(db));
}

SessionIndex SessionIndex::open_for_update(const std::filesystem::path& path, std::vector<int>* migrated,
                                           const std::function<void(const std::string&)>& progress) {
  if (!std::filesystem::exists(path)) throw sqlite::SqliteError(0, fmt::format("{}: no such file", path.string()));
  auto db = std::make_unique<sqlite::Database>(path, sqlite::Database::Mode::ReadWrite);
  db->apply_resilient_pragmas();
  const int version = db->user_version();
  if (version < kSchemaVersion && version >= 1) back_up_before_migration(path, version);
  auto passed = migrate_schema(*db, progress);
  if (migrated) *migrated = std::move(passed);
  return SessionIndex(std::move(db));
}

namespace {
// A CRC-32 as SQLite stores it: an unsigned 32-bit number in an INTEGER column.
std::optional<std::int64_t> checksum_column(std::optional<std::uint32_t> crc) {
  if (!crc) return std::nullopt;
  return std::int64_t(*crc);
}
}  // namespace

SessionIndex::SessionIndex(std::unique_ptr<sqlite::Database> db) : db_(std::move(db)) {
  insert_frame_.emplace(db_->prepare(
      "INSERT INTO frames (device_id, connection, sequence, frame_id, device_ns, host_ns, aravis_system_ns, status, "
      "kept, reason, video_file_id, video_index, mapped_ns, video_pts_ms, checksum, chunk_frame_counter, "
      "chunk_timestamp, chunk_exposure_us, chunk_gain, chunk_line_status) "
      "VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)"));
  insert_drop_.emplace(db_->prepare(
      "INSERT INTO drops (device_id, connection, first_sequence, count, reason, host_ns) VALUES (?,?,?,?,?,?)"));
  insert_pressure_.emplace(db_->prepare(
      "INSERT INTO pressure_frames (device_id, connection, sequence, lost_before, device_ns, host_ns, host_wait_ns, "
      "grid_cols, grid_rows, grid_xscale, grid_yscale, payload, mapped_ns, base, counts, checksum) "
      "VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)"));
  insert_sample_.emplace(db_->prepare(
      "INSERT INTO samples (id, tick, tick_ns, t_ns, span_ns, cameras, pressure_device_id, pressure_connection, "
      "pressure_sequence, pressure_offset_ns, before_sequence, before_offset_ns, after_sequence, after_offset_ns) "
      "VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?)"));
  insert_sample_frame_.emplace(db_->prepare(
      "INSERT INTO sample_frames (sample_id, device_id, connection, sequence, offset_ns) VALUES (?,?,?,?,?)"));
  insert_clock_.emplace(db_->prepare(
      "INSERT INTO clock_models (device_id, host_ns, segment, x0_device_ns, offset_ns, skew, latency_ns, source, "
      "pairs, envelope_points, residual_p50_ns, residual_p99_ns) VALUES (?,?,?,?,?,?,?,?,?,?,?,?)"));
  insert_event_.emplace(db_->prepare("INSERT INTO events (host_ns, kind, device_id, message) VALUES (?,?,?,?)"));
}

std::int64_t SessionIndex::add_session(const SessionRecord& s) {
  db_->prepare(
         "INSERT INTO session (started_wall_ns, started_host_ns, pvcap_version, rig_name, rig_path, rig_config, "
         "simulated) VALUES (?,?,?,?,?,?,?)")
      .bind_all(s.started_wall_ns, s.started_host_ns, s.pvcap_version, s.rig_name, s.rig_path, s.rig_config,
                int(s.simulated))
      .run();
  return db_->last_insert_rowid();
}

std::int64_t SessionIndex::add_device(const DeviceRecord& d) {
  db_->prepare(
         "INSERT INTO devices (kind, name, vendor, model, serial, address, firmware, settings_json) "
         "VALUES (?,?,?,?,?,?,?,?)")
      .bind_all(d.kind, d.name, d.vendor, d.model, d.serial, d.address, d.firmware, d.settings_json)
      .run();
  return db_->last_insert_rowid();
}

void SessionIndex::add_video_file(const VideoFileRecord& v) {
  db_->prepare(
         "INSERT INTO video_files (id, device_id, path, codec, pixel_format, width, height, segment, state, layout, "
         "bayer_format, bit_depth) VALUES (?,?,?,?,?,?,?,?,'open',?,?,?)")
      .bind_all(v.id, v.device_id, v.path, v.codec, v.pixel_format, v.width, v.height, v.segment, v.layout,
                v.bayer_format, v.bit_depth)
      .run();
}

void SessionIndex::close_video_file(const VideoFileClosed& v) {
  db_->prepare("UPDATE video_files SET state = 'closed', frames = ? WHERE id = ?").bind_all(v.frames, v.id).run();
}

void SessionIndex::set_participant(const ParticipantRecord& p) {
  db_->exec("DELETE FROM participant");
  db_->prepare("INSERT INTO participant (pseudonym, skin_tone, hand_order) VALUES (?,?,?)")
      .bind_all(p.pseudonym, p.skin_tone, p.hand_order)
      .run();
}

void SessionIndex::set_conditions(const ConditionsRecord& c) {
  db_->exec("DELETE FROM conditions");
  db_->prepare("INSERT INTO conditions (lighting, sensor_overlay) VALUES (?,?)")
      .bind_all(c.lighting, c.sensor_overlay)
      .run();
}

std::int64_t SessionIndex::add_calibration(const CalibrationRecord& c) {
  db_->prepare(
         "INSERT INTO calibrations (device_id, created_wall_ns, method, homography, rms_px, rms_mm, details_json) "
         "VALUES (?,?,?,?,?,?,?)")
      .bind_all(c.device_id, c.created_wall_ns, c.method, c.homography_json, c.rms_px, c.rms_mm, c.details_json)
      .run();
  return db_->last_insert_rowid();
}

void SessionIndex::add(const IndexRecord& record) {
  std::visit(
      [&](const auto& r) {
        using T = std::decay_t<decltype(r)>;
        if constexpr (std::is_same_v<T, FrameRecord>)
          add_frame(r);
        else if constexpr (std::is_same_v<T, PressureRecord>)
          add_pressure(r);
        else if constexpr (std::is_same_v<T, DropRecord>)
          add_drop(r);
        else if constexpr (std::is_same_v<T, SampleRecord>)
          add_sample(r);
        else if constexpr (std::is_same_v<T, ClockModelRecord>)
          add_clock_model(r);
        else if constexpr (std::is_same_v<T, VideoFileRecord>)
          add_video_file(r);
        else if constexpr (std::is_same_v<T, VideoFileClosed>)
          close_video_file(r);
        else if constexpr (std::is_same_v<T, ProtocolEventRecord>)
          add_protocol_event(r);
        else if constexpr (std::is_same_v<T, OperatorNoteRecord>)
          add_operator_note(r);
        else if constexpr (std::is_same_v<T, EventRecord>)
          add_event(r);
      },
      record);
}

bool SessionIndex::holds(const IndexRecord& record) {
  // bind_all returns the statement, which lives to the end of the full expression.
  const auto found = [](sqlite::Statement& q) { return q.step(); };
  return std::visit(
      [&](const auto& r) {
        using T = std::decay_t<decltype(r)>;
        if constexpr (std::is_same_v<T, FrameRecord>)
          return found(db_->prepare("SELECT 1 FROM frames WHERE device_id = ? AND connection = ? AND sequence = ?")
                           .bind_all(r.device_id, std::int64_t(r.connection), r.sequence));
        else if constexpr (std::is_same_v<T, PressureRecord>)
          return found(
              db_->prepare("SELECT 1 FROM pressure_frames WHERE device_id = ? AND connection = ? AND sequence = ?")
                  .bind_all(r.device_id, std::int64_t(r.connection), r.sequence));
        else if constexpr (std::is_same_v<T, DropRecord>)
          return found(db_->prepare("SELECT 1 FROM drops WHERE device_id = ? AND connection = ? AND "
                                    "first_sequence = ? AND reason = ?")
                           .bind_all(r.device_id, std::int64_t(r.connection), r.first_sequence, r.reason));
        else if constexpr (std::is_same_v<T, SampleRecord>)
          return found(db_->prepare("SELECT 1 FROM samples WHERE id = ?").bind_all(r.index));
        else if constexpr (std::is_same_v<T, ClockModelRecord>)
          return found(db_->prepare("SELECT 1 FROM clock_models WHERE device_id = ? AND host_ns = ? AND segment = ?")
                           .bind_all(r.device_id, r.host_ns, r.segment));
        else if constexpr (std::is_same_v<T, VideoFileRecord>)
          return found(db_->prepare("SELECT 1 FROM video_files WHERE id = ?").bind_all(r.id));
        else if constexpr (std::is_same_v<T, VideoFileClosed>)
          return found(db_->prepare("SELECT 1 FROM video_files WHERE id = ? AND state = 'closed' AND frames = ?")
                           .bind_all(r.id, r.frames));
        else if constexpr (std::is_same_v<T, ProtocolEventRecord>)
          return found(
              db_->prepare("SELECT 1 FROM protocol_events WHERE host_ns = ? AND kind = ?").bind_all(r.host_ns, r.kind));
        else if constexpr (std::is_same_v<T, OperatorNoteRecord>)
          return found(
              db_->prepare("SELECT 1 FROM operator_notes WHERE host_ns = ? AND text = ?").bind_all(r.host_ns, r.text));
        else
          return found(db_->prepare("SELECT 1 FROM events WHERE host_ns = ? AND kind = ? AND message = ?")
                           .bind_all(r.host_ns, r.kind, r.message));
      },
      record);
}

void SessionIndex::add_protocol_event(const ProtocolEventRecord& e) {
  db_->prepare(
         "INSERT INTO protocol_events (host_ns, kind, step, action, hand, force, repetition, detail) "
         "VALUES (?,?,?,?,?,?,?,?)")
      .bind_all(e.host_ns, e.kind, e.step, e.action, e.hand, e.force, e.repetition, e.detail)
      .run();
}

void SessionIndex::add_operator_note(const OperatorNoteRecord& n) {
  db_->prepare("INSERT INTO operator_notes (host_ns, text) VALUES (?,?)").bind_all(n.host_ns, n.text).run();
}

void SessionIndex::add_frame(const FrameRecord& f) {
  insert_frame_
      ->bind_all(f.device_id, std::int64_t(f.connection), f.sequence, f.frame_id, f.device_ns, f.host_ns,
                 f.aravis_system_ns, f.status, int(f.kept), f.reason, f.video_file_id, f.video_index, f.mapped_ns,
                 f.video_pts_ms, checksum_column(f.checksum), f.chunk_frame_counter, f.chunk_timestamp,
                 f.chunk_exposure_us, f.chunk_gain, f.chunk_line_status)
      .run();
}

void SessionIndex::add_drop(const DropRecord& d) {
  insert_drop_->bind_all(d.device_id, std::int64_t(d.connection), d.first_sequence, d.count, d.reason, d.host_ns).run();
}

void SessionIndex::add_pressure(const PressureRecord& p) {
  std::optional<std::int64_t> base;
  std::optional<std::vector<std::uint8_t>> counts;
  if (!p.counts.empty()) base = p.base, counts = compress_counts(p.counts);
  insert_pressure_
      ->bind_all(p.device_id, std::int64_t(p.connection), p.sequence, p.lost_before, p.device_ns, p.host_ns,
                 p.host_wait_ns, p.grid_cols, p.grid_rows, p.grid_xscale, p.grid_yscale, p.payload, p.mapped_ns, base,
                 counts, checksum_column(p.checksum))
      .run();
}

void SessionIndex::add_event(const EventRecord& e) {
  insert_event_->bind_all(e.host_ns, e.kind, e.device_id, e.message).run();
}

void SessionIndex::add_stream_stats(const StreamStatsRecord& s) {
  db_->prepare(
         "INSERT INTO stream_stats (device_id, completed, failures, underruns, resent_packets, missing_packets, "
         "queue_overflows) VALUES (?,?,?,?,?,?,?)")
      .bind_all(s.device_id, s.completed, s.failures, s.underruns, s.resent_packets, s.missing_packets,
                s.queue_overflows)
      .run();
}

namespace {
// The samples table's pressure columns, from a record: the Sensel's device and connection (from
// whichever frame is present), then sequence and offset of the nearest, the one before, the one after.
struct PressureColumns {
  std::optional<std::int64_t> device, connection, seq, off, before_seq, before_off, after_seq, after_off;
  explicit PressureColumns(const SampleRecord& s) {
    const auto* any = s.pressure          ? &*s.pressure
                      : s.pressure_before ? &*s.pressure_before
                      : s.pressure_after  ? &*s.pressure_after
                                          : nullptr;
    if (any) device = any->device_id, connection = std::int64_t(any->connection);
    if (s.pressure) seq = std::int64_t(s.pressure->sequence), off = s.pressure->offset_ns;
    if (s.pressure_before)
      before_seq = std::int64_t(s.pressure_before->sequence), before_off = s.pressure_before->offset_ns;
    if (s.pressure_after) after_seq = std::int64_t(s.pressure_after->sequence), after_off = s.pressure_after->offset_ns;
  }
};
}  // namespace

void SessionIndex::add_sample(const SampleRecord& s) {
  const PressureColumns p(s);
  insert_sample_
      ->bind_all(std::int64_t(s.index), s.tick, s.tick_ns, s.t_ns, s.span_ns, std::int64_t(s.cameras.size()), p.device,
                 p.connection, p.seq, p.off, p.before_seq, p.before_off, p.after_seq, p.after_off)
      .run();
  for (const auto& c : s.cameras)
    insert_sample_frame_
        ->bind_all(std::int64_t(s.index), c.device_id, std::int64_t(c.connection), c.sequence, c.offset_ns)
        .run();
}

void SessionIndex::add_clock_model(const ClockModelRecord& c) {
  insert_clock_
      ->bind_all(c.device_id, c.host_ns, c.segment, c.x0_device_ns, c.offset_ns, c.skew, c.latency_ns, c.source,
                 c.pairs, c.envelope_points, c.residual_p50_ns, c.residual_p99_ns)
      .run();
}

void SessionIndex::add_timeline_count(const std::string& what, std::uint64_t count) {
  db_->prepare("INSERT INTO timeline_counts (what, count) VALUES (?,?)").bind_all(what, count).run();
}

void SessionIndex::finish_session(std::int64_t ended_host_ns, const std::string& end_reason) {
  db_->prepare("UPDATE session SET ended_host_ns = ?, end_reason = ?").bind_all(ended_host_ns, end_reason).run();
}

void SessionIndex::remap(Stream stream, std::int64_t device_id, std::int64_t from_arrival_ns,
                         std::int64_t to_arrival_ns, std::int64_t x0, double offset_ns, double skew,
                         std::int64_t latency_ns) {
  // The clock model's one mapping function (sync/clock_fit.h), applied by SQLite row by row.
  db_->define_function("pvcap_map", &sync::map_device_time);
  if (stream == Stream::Pressure) {
    db_->prepare(
           "UPDATE pressure_frames SET mapped_ns = pvcap_map(device_ns, ?3, ?1, ?2, ?4) WHERE device_id = ?5 AND "
           "mapped_ns IS NOT NULL AND host_ns + host_wait_ns / 2 >= ?6 AND host_ns + host_wait_ns / 2 < ?7")
        .bind_all(offset_ns, skew, x0, latency_ns, device_id, from_arrival_ns, to_arrival_ns)
        .run();
    return;
  }
  // A frame whose chunks give its own exposure: its image's instant moves by half the difference from
  // the exposure the camera's constant offset was taken from (capture/aravis_chunks.h), as live. A
  // device row without settings (a test's, an older store's) has no chunks either: no correction.
  double per_exposure_us = 0;  // ns of instant per us of exposure: 500 for stamps at the exposure's start
  std::int64_t constant_ns = 0;
  {
    auto q = db_->prepare(
        "SELECT coalesce(json_extract(settings_json, '$.timestamp_marks'), ''), "
        "coalesce(json_extract(settings_json, '$.stamp_to_mid_exposure_ns'), 0) FROM devices WHERE id = ? AND "
        "json_valid(settings_json)");
    q.bind_all(device_id);
    if (q.step()) {
      const std::string marks = q.column_text(0);
      per_exposure_us = marks == "exposure_start" ? 500.0 : marks == "exposure_end" ? -500.0 : 0.0;
      constant_ns = q.column_int(1);
    }
  }
  db_->prepare(
         "UPDATE frames SET mapped_ns = pvcap_map(device_ns + coalesce(CAST(round(chunk_exposure_us * ?8) AS "
         "INTEGER) - ?9, 0), ?3, ?1, ?2, ?4) WHERE device_id = ?5 AND mapped_ns IS NOT NULL AND host_ns >= ?6 AND "
         "host_ns < ?7")
      .bind_all(offset_ns, skew, x0, latency_ns, device_id, from_arrival_ns, to_arrival_ns, per_exposure_us,
                constant_ns)
      .run();
}

std::vector<SessionIndex::StoredClocks> SessionIndex::stored_clocks() {
  std::vector<StoredClocks> out;
  auto q = db_->prepare(
      "SELECT m.device_id, d.kind = 'sensel', m.segment, m.host_ns, m.x0_device_ns, m.offset_ns, m.skew, m.latency_ns "
      "FROM clock_models m JOIN devices d ON d.id = m.device_id ORDER BY m.device_id, m.segment, m.host_ns");
  int segment = -1;
  while (q.step()) {
    const std::int64_t device = q.column_int(0);
    if (out.empty() || out.back().device_id != device) {
      out.push_back({device, q.column_int(1) != 0, {}});
      segment = -1;
    }
    auto& segments = out.back().segments;
    const int s = int(q.column_int(2));
    if (s != segment) {
      segments.push_back({q.column_int(3), 0, 0, 0, 0});
      segment = s;
    }
    StoredSegment& seg = segments.back();
    seg.x0 = q.column_int(4);
    seg.offset_ns = q.column_double(5);
    seg.skew = q.column_double(6);
    seg.latency_ns = q.column_int(7);
  }
  return out;
}

bool SessionIndex::realign_pending() {
  auto q = db_->prepare(
      "SELECT (SELECT max(rowid) FROM events WHERE kind = 'realign_started'), (SELECT max(rowid) FROM events WHERE "
      "kind = 'realign_done')");
  if (!q.step() || q.column_null(0)) return false;
  return q.column_null(1) || q.column_int(1) < q.column_int(0);
}

std::vector<SessionIndex::MappedRef> SessionIndex::mapped(Stream stream, std::int64_t device_id) {
  auto q = db_->prepare(stream == Stream::Camera
                            ? "SELECT connection, sequence, mapped_ns FROM frames WHERE device_id = ? AND mapped_ns IS "
                              "NOT NULL ORDER BY mapped_ns"
                            : "SELECT connection, sequence, mapped_ns FROM pressure_frames WHERE device_id = ? AND "
                              "mapped_ns IS NOT NULL ORDER BY mapped_ns");
  q.bind_all(device_id);
  std::vector<MappedRef> out;
  while (q.step()) out.push_back({std::uint32_t(q.column_int(0)), std::uint64_t(q.column_int(1)), q.column_int(2)});
  return out;
}

std::vector<SessionIndex::SampleMembers> SessionIndex::sample_members() {
  auto q = db_->prepare(
      "SELECT s.id, s.tick_ns, s.t_ns, s.span_ns, sf.device_id, sf.connection, sf.sequence, sf.offset_ns FROM "
      "samples s LEFT JOIN sample_frames sf ON sf.sample_id = s.id ORDER BY s.id");
  std::vector<SampleMembers> out;
  while (q.step()) {
    const auto id = std::uint64_t(q.column_int(0));
    if (out.empty() || out.back().id != id) out.push_back({id, q.column_int(1), q.column_int(2), q.column_int(3), {}});
    if (!q.column_null(4))
      out.back().frames.push_back(
          {q.column_int(4), std::uint32_t(q.column_int(5)), std::uint64_t(q.column_int(6)), q.column_int(7)});
  }
  return out;
}

void SessionIndex::update_sample(const SampleRecord& s) {
  if (!update_sample_) {  // prepared once: a re-mapping rewrites every sample of the session
    update_sample_.emplace(db_->prepare(
        "UPDATE samples SET t_ns = ?, span_ns = ?, pressure_device_id = ?, pressure_connection = ?, "
        "pressure_sequence = ?, pressure_offset_ns = ?, before_sequence = ?, before_offset_ns = ?, after_sequence = ?, "
        "after_offset_ns = ? WHERE id = ?"));
    update_sample_frame_.emplace(
        db_->prepare("UPDATE sample_frames SET offset_ns = ? WHERE sample_id = ? AND device_id = ? AND connection = ? "
                     "AND sequence = ?"));
  }
  const PressureColumns p(s);
  update_sample_
      ->bind_all(s.t_ns, s.span_ns, p.device, p.connection, p.seq, p.off, p.before_seq, p.before_off, p.after_seq,
                 p.after_off, std::int64_t(s.index))
      .run();
  for (const auto& c : s.cameras)
    update_sample_frame_
        ->bind_all(c.offset_ns, std::int64_t(s.index), c.device_id, std::int64_t(c.connection), c.sequence)
        .run();
}

std::optional<SessionIndex::RecordedRig> SessionIndex::recorded_rig() {
  auto q = db_->prepare("SELECT rig_config, rig_path FROM session");
  if (!q.step()) return std::nullopt;
  return RecordedRig{q.column_text(0), q.column_text(1)};
}

std::string SessionIndex::device_name(std::int64_t device_id) {
  auto q = db_->prepare("SELECT name FROM devices WHERE id = ?");
  q.bind_all(device_id);
  return q.step() ? q.column_text(0) : fmt::format("device {}", device_id);
}

void SessionIndex::leave_sample(std::uint64_t sample_id, const SampleFrameRef& f) {
  const auto id = std::int64_t(sample_id);
  const auto connection = std::int64_t(f.connection);
  const auto sequence = std::int64_t(f.sequence);
  db_->prepare("DELETE FROM sample_frames WHERE sample_id = ? AND device_id = ? AND connection = ? AND sequence = ?")
      .bind_all(id, f.device_id, connection, sequence)
      .run();
  if (db_->changes() == 0) return;  // already out (a re-mapping run again)
  db_->prepare("UPDATE samples SET cameras = cameras - 1 WHERE id = ?").bind_all(id).run();
  db_->prepare(
         "UPDATE frames SET reason = 'outside_its_group' WHERE device_id = ? AND connection = ? AND sequence = ? "
         "AND kept = 1")
      .bind_all(f.device_id, connection, sequence)
      .run();
}

}  // namespace pvcap
