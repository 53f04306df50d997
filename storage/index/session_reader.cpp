#include "storage/index/session_reader.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "storage/index/database.h"
#include "storage/index/pressure_blob.h"
#include "storage/index/session_reader_internal.h"

namespace pvcap {

using session_reader_detail::guarded;
using session_reader_detail::opt_int;
using session_reader_detail::text_or_empty;

namespace {
constexpr int kMaxGridSide = 1024;  // the Morph's grids are at most 185 x 105: anything bigger is damage

constexpr const char* kSampleColumns =
    "SELECT id, tick, tick_ns, t_ns, span_ns, pressure_sequence, pressure_offset_ns, before_sequence, "
    "before_offset_ns, after_sequence, after_offset_ns, pressure_connection FROM samples ";

// A samples row (kSampleColumns) without its camera frames.
SampleInfo sample_row(const sqlite::Statement& q) {
  SampleInfo s;
  s.index = std::uint64_t(q.column_int(0));
  s.tick = q.column_int(1);
  s.tick_ns = q.column_int(2);
  s.t_ns = q.column_int(3);
  s.span_ns = q.column_int(4);
  auto ref = [&](int col) -> std::optional<SampleInfo::PressureRef> {
    if (q.column_null(col)) return std::nullopt;
    return SampleInfo::PressureRef{std::uint64_t(q.column_int(col)), q.column_int(col + 1),
                                   q.column_null(11) ? 0u : std::uint32_t(q.column_int(11))};
  };
  s.pressure = ref(5);
  s.before = ref(7);
  s.after = ref(9);
  return s;
}
}  // namespace

cv::Mat PressureFrame::image() const {
  cv::Mat m(grid_rows, grid_cols, CV_32F);
  for (int i = 0; i < grid_rows * grid_cols && std::size_t(i) < counts.size(); ++i) m.at<float>(i) = float(counts[i]);
  return m;
}

SessionReader::~SessionReader() = default;

Result<std::unique_ptr<SessionReader>> SessionReader::open(const std::filesystem::path& dir) {
  const auto db_path = dir / "session.db";
  if (!std::filesystem::is_regular_file(db_path))
    return Error{fmt::format("{}: not a session folder (no session.db)", dir.string())};
  std::unique_ptr<SessionReader> r(new SessionReader());
  r->dir_ = dir;
  r->views_ = ViewVideoReader(dir);
  auto loaded = guarded(dir, [&]() -> Status {
    r->db_ = std::make_unique<sqlite::Database>(db_path, sqlite::Database::Mode::ReadOnly);
    auto& db = *r->db_;
    const int version = db.user_version();
    if (version < kOldestReadableSchemaVersion || version > kSchemaVersion)
      return Error{version >= 1 && version < kOldestReadableSchemaVersion
                       ? fmt::format("{}: store version {} was written by an older pvcap: 'pvcap migrate {}' "
                                     "upgrades it",
                                     db_path.string(), version, dir.string())
                       : fmt::format("{}: store version {} is not one this pvcap reads ({})", db_path.string(), version,
                                     kSchemaVersion)};
    SessionInfo& in = r->info_;
    in.schema_version = version;
    auto s = db.prepare(
        "SELECT started_wall_ns, started_host_ns, ended_host_ns, end_reason, pvcap_version, rig_name, "
        "rig_config, simulated, rig_path FROM session");
    if (!s.step()) return Error{fmt::format("{}: holds no session", db_path.string())};
    in.started_wall_ns = s.column_int(0);
    in.started_host_ns = s.column_int(1);
    in.ended_host_ns = opt_int(s, 2);
    in.end_reason = text_or_empty(s, 3);
    in.pvcap_version = text_or_empty(s, 4);
    in.rig_name = text_or_empty(s, 5);
    in.rig_config = text_or_empty(s, 6);
    in.simulated = s.column_int(7) != 0;
    in.rig_path = text_or_empty(s, 8);
    if (auto p = db.prepare("SELECT pseudonym, skin_tone, hand_order FROM participant"); p.step())
      in.participant = ParticipantRecord{p.column_text(0), p.column_text(1), p.column_text(2)};
    if (auto c = db.prepare("SELECT lighting, sensor_overlay FROM conditions"); c.step())
      in.conditions = ConditionsRecord{c.column_text(0), c.column_text(1)};
    auto cams = db.prepare(
        "SELECT d.id, d.name, d.serial, v.width, v.height, "
        "coalesce(json_extract(CASE WHEN json_valid(d.settings_json) THEN d.settings_json END, "
        "'$.stamp_to_mid_exposure_ns'), 0) FROM devices d JOIN video_files v ON v.device_id = d.id "
        "WHERE d.kind = 'camera' GROUP BY d.id ORDER BY d.id");
    while (cams.step()) {
      CameraInfo c{cams.column_int(0),      cams.column_text(1),     text_or_empty(cams, 2),
                   int(cams.column_int(3)), int(cams.column_int(4)), cams.column_int(5)};
      if (c.width <= 0 || c.height <= 0 || c.width > 16384 || c.height > 16384)
        return Error{
            fmt::format("{}: camera {} has an impossible size {}x{}", db_path.string(), c.name, c.width, c.height)};
      if (std::abs(c.stamp_to_instant_ns) > 10'000'000'000)
        return Error{fmt::format("{}: camera {} has an impossible time from stamp to image ({} ns)", db_path.string(),
                                 c.name, c.stamp_to_instant_ns)};
      r->cameras_.push_back(std::move(c));
    }
    if (auto p = db.prepare("SELECT id, name, serial FROM devices WHERE kind = 'sensel' ORDER BY id"); p.step())
      r->pressure_device_ = PressureDeviceInfo{p.column_int(0), p.column_text(1), text_or_empty(p, 2)};
    auto samples = db.prepare("SELECT id, t_ns FROM samples ORDER BY id");
    while (samples.step()) {
      r->sample_ids_.push_back(std::uint64_t(samples.column_int(0)));
      r->sample_times_.push_back(samples.column_int(1));
    }
    return {};
  });
  if (!loaded.ok()) return loaded.error();
  return r;
}

Result<SampleInfo> SessionReader::sample_info(std::size_t i) {
  if (i >= sample_ids_.size())
    return Error{fmt::format("{}: no sample {} (the session has {})", dir_.string(), i, sample_ids_.size())};
  return guarded(dir_, [&]() -> Result<SampleInfo> {
    auto q = db_->cached(std::string(kSampleColumns) + "WHERE id = ?");
    q.bind_all(std::int64_t(sample_ids_[i]));
    if (!q.step()) return Error{fmt::format("{}: sample {} vanished from the index", dir_.string(), i)};
    SampleInfo s = sample_row(q);
    auto f = db_->cached(
        "SELECT sf.device_id, sf.connection, sf.sequence, sf.offset_ns, f.kept, f.reason FROM sample_frames sf "
        "LEFT JOIN frames f USING (device_id, connection, sequence) WHERE sf.sample_id = ? ORDER BY sf.device_id");
    f.bind_all(std::int64_t(s.index));
    while (f.step())
      s.cameras.push_back({f.column_int(0), std::uint32_t(f.column_int(1)), std::uint64_t(f.column_int(2)),
                           f.column_int(3), !f.column_null(4) && f.column_int(4) == 1,
                           f.column_null(4) ? "no frame row" : text_or_empty(f, 5)});
    return s;
  });
}

namespace {
constexpr const char* kPressureColumns =
    "SELECT sequence, device_ns, host_ns, mapped_ns, grid_cols, grid_rows, grid_xscale, grid_yscale, base, counts "
    "FROM pressure_frames ";

Result<PressureFrame> pressure_row(sqlite::Statement& q, const std::filesystem::path& dir) {
  PressureFrame p;
  p.sequence = std::uint64_t(q.column_int(0));
  p.device_ns = q.column_int(1);
  p.host_ns = q.column_int(2);
  p.mapped_ns = opt_int(q, 3);
  p.grid_cols = int(q.column_int(4));
  p.grid_rows = int(q.column_int(5));
  p.grid_xscale = int(q.column_int(6));
  p.grid_yscale = int(q.column_int(7));
  if (p.grid_cols <= 0 || p.grid_rows <= 0 || p.grid_cols > kMaxGridSide || p.grid_rows > kMaxGridSide)
    return Error{fmt::format("{}: pressure frame {} has an impossible grid {}x{}", dir.string(), p.sequence,
                             p.grid_cols, p.grid_rows)};
  if (q.column_null(9))
    return Error{fmt::format("{}: pressure frame {} carries no pressure image", dir.string(), p.sequence)};
  p.base = std::uint16_t(q.column_int(8));
  auto counts = decompress_counts(q.column_blob(9), std::size_t(p.grid_cols) * std::size_t(p.grid_rows));
  if (!counts) return Error{fmt::format("{}: pressure frame {}: {}", dir.string(), p.sequence, counts.error().message)};
  p.counts = std::move(counts.value());
  return p;
}
}  // namespace

Result<PressureFrame> SessionReader::pressure_frame(std::uint64_t sequence, std::uint32_t connection) {
  if (!pressure_device_) return Error{fmt::format("{}: the session has no pressure sensor", dir_.string())};
  return guarded(dir_, [&]() -> Result<PressureFrame> {
    auto q = db_->cached(std::string(kPressureColumns) + "WHERE device_id = ? AND connection = ? AND sequence = ?");
    q.bind_all(pressure_device_->device_id, std::int64_t(connection), sequence);
    if (!q.step()) return Error{fmt::format("{}: no pressure frame {}", dir_.string(), sequence)};
    return pressure_row(q, dir_);
  });
}

Result<std::vector<PressureFrame>> SessionReader::pressure_frames_between(std::int64_t from_ns, std::int64_t to_ns) {
  if (!pressure_device_) return Error{fmt::format("{}: the session has no pressure sensor", dir_.string())};
  return guarded(dir_, [&]() -> Result<std::vector<PressureFrame>> {
    // By arrival (indexed), a second wider than asked, then by the session clock.
    auto q = db_->prepare(std::string(kPressureColumns) +
                          "WHERE device_id = ? AND host_ns BETWEEN ? AND ? ORDER BY host_ns");
    q.bind_all(pressure_device_->device_id, from_ns - 1'000'000'000, to_ns + 1'000'000'000);
    std::vector<PressureFrame> out;
    while (q.step()) {
      auto p = pressure_row(q, dir_);
      if (!p) return p.error();
      const std::int64_t t = p.value().mapped_ns.value_or(p.value().host_ns);
      if (t >= from_ns && t < to_ns) out.push_back(std::move(p.value()));
    }
    return out;
  });
}

Result<Sample> SessionReader::sample(std::size_t i, PressureMode mode) {
  auto info = sample_info(i);
  if (!info) return info.error();
  Sample s;
  s.info = std::move(info.value());
  s.images.resize(cameras_.size());
  for (const auto& c : s.info.cameras) {
    const auto cam =
        std::find_if(cameras_.begin(), cameras_.end(), [&](const auto& k) { return k.device_id == c.device_id; });
    if (cam == cameras_.end() || !c.in_video) continue;  // not stored: the caller sees an empty image and c.reason
    auto image = camera_image(c);
    if (!image) return image.error();
    s.images[std::size_t(cam - cameras_.begin())] = std::move(image.value());
  }
  if (s.info.pressure) {
    auto p = pressure_frame(s.info.pressure->sequence, s.info.pressure->connection);
    if (!p) return p.error();
    s.pressure = std::move(p.value());
    s.pressure_image = s.pressure->image();
    if (mode == PressureMode::Interpolated && s.info.before && s.info.after &&
        s.info.after->offset_ns > s.info.before->offset_ns) {
      auto a = pressure_frame(s.info.before->sequence, s.info.before->connection);
      auto b = pressure_frame(s.info.after->sequence, s.info.after->connection);
      if (a && b && a.value().counts.size() == b.value().counts.size() && a.value().grid_cols == b.value().grid_cols) {
        // Weight of the later frame: where the sample's instant (offset 0) lies between the two.
        const double w = double(-s.info.before->offset_ns) / double(s.info.after->offset_ns - s.info.before->offset_ns);
        cv::addWeighted(a.value().image(), 1.0 - std::clamp(w, 0.0, 1.0), b.value().image(), std::clamp(w, 0.0, 1.0),
                        0.0, s.pressure_image);
      }
    }
  }
  return s;
}

Result<std::size_t> SessionReader::sample_at(std::int64_t t_ns) const {
  if (sample_times_.empty()) return Error{fmt::format("{}: the session has no samples", dir_.string())};
  // Sample times increase with their index (one per tick); nearest by binary search.
  const auto it = std::lower_bound(sample_times_.begin(), sample_times_.end(), t_ns);
  std::size_t i = std::size_t(it - sample_times_.begin());
  if (i == sample_times_.size()) return i - 1;
  if (i > 0 && std::llabs(sample_times_[i - 1] - t_ns) <= std::llabs(sample_times_[i] - t_ns)) --i;
  return i;
}

Result<std::vector<ProtocolEventRecord>> SessionReader::protocol_events() {
  return guarded(dir_, [&]() -> Result<std::vector<ProtocolEventRecord>> {
    std::vector<ProtocolEventRecord> out;
    auto q = db_->prepare(
        "SELECT host_ns, kind, step, action, hand, force, repetition, detail FROM protocol_events ORDER BY host_ns, "
        "id");
    while (q.step())
      out.push_back({q.column_int(0), q.column_text(1), opt_int(q, 2), text_or_empty(q, 3), text_or_empty(q, 4),
                     text_or_empty(q, 5), opt_int(q, 6), text_or_empty(q, 7)});
    return out;
  });
}

Result<std::vector<ActionSpan>> SessionReader::actions() {
  auto events = protocol_events();
  if (!events) return events.error();
  std::vector<ActionSpan> out;
  std::optional<ActionSpan> open;
  const std::int64_t session_end = info_.ended_host_ns.value_or(sample_times_.empty() ? 0 : sample_times_.back() + 1);
  auto close = [&](std::int64_t end) {
    if (!open) return;
    open->end_ns = end;
    open->first_sample = std::size_t(std::lower_bound(sample_times_.begin(), sample_times_.end(), open->start_ns) -
                                     sample_times_.begin());
    open->end_sample =
        std::size_t(std::lower_bound(sample_times_.begin(), sample_times_.end(), end) - sample_times_.begin());
    out.push_back(*open);
    open.reset();
  };
  for (const auto& e : events.value()) {
    if (e.kind == "action_start") {
      close(e.host_ns);  // a start without an end closes the one before
      open = ActionSpan{e.step, e.action, e.hand, e.force, e.repetition, e.host_ns, 0, 0, 0};
    } else if (e.kind == "action_end") {
      close(e.host_ns);
    }
  }
  // An action still open runs to the end of the data (the session's end, or its last sample).
  close(std::max({session_end, open ? open->start_ns : 0, sample_times_.empty() ? 0 : sample_times_.back() + 1}));
  return out;
}

Result<std::vector<EventRecord>> SessionReader::events() {
  return guarded(dir_, [&]() -> Result<std::vector<EventRecord>> {
    std::vector<EventRecord> out;
    auto q = db_->prepare("SELECT host_ns, kind, device_id, message FROM events ORDER BY host_ns");
    while (q.step()) out.push_back({q.column_int(0), q.column_text(1), opt_int(q, 2), text_or_empty(q, 3)});
    return out;
  });
}

Result<std::vector<OperatorNoteRecord>> SessionReader::operator_notes() {
  return guarded(dir_, [&]() -> Result<std::vector<OperatorNoteRecord>> {
    std::vector<OperatorNoteRecord> out;
    auto q = db_->prepare("SELECT host_ns, text FROM operator_notes ORDER BY host_ns");
    while (q.step()) out.push_back({q.column_int(0), q.column_text(1)});
    return out;
  });
}

Result<std::vector<CalibrationRecord>> SessionReader::calibrations() {
  return guarded(dir_, [&]() -> Result<std::vector<CalibrationRecord>> {
    std::vector<CalibrationRecord> out;
    auto q = db_->prepare(
        "SELECT device_id, created_wall_ns, method, homography, rms_px, rms_mm, details_json FROM calibrations ORDER "
        "BY id");
    while (q.step()) {
      CalibrationRecord c{q.column_int(0),    q.column_int(1), q.column_text(2), q.column_text(3), {}, {},
                          text_or_empty(q, 6)};
      if (!q.column_null(4)) c.rms_px = q.column_double(4);
      if (!q.column_null(5)) c.rms_mm = q.column_double(5);
      out.push_back(std::move(c));
    }
    return out;
  });
}

Result<std::vector<std::pair<std::string, std::string>>> SessionReader::camera_settings() {
  return guarded(dir_, [&]() -> Result<std::vector<std::pair<std::string, std::string>>> {
    std::vector<std::pair<std::string, std::string>> out;
    auto q = db_->prepare("SELECT name, settings_json FROM devices WHERE kind = 'camera' ORDER BY id");
    while (q.step()) out.emplace_back(q.column_text(0), text_or_empty(q, 1));
    return out;
  });
}

Result<std::vector<StreamStatistics>> SessionReader::stream_statistics() {
  return guarded(dir_, [&]() -> Result<std::vector<StreamStatistics>> {
    std::vector<StreamStatistics> out;
    auto d = db_->prepare("SELECT id, name, kind FROM devices ORDER BY id");
    while (d.step()) {
      StreamStatistics s;
      s.device_id = d.column_int(0);
      s.name = d.column_text(1);
      s.kind = d.column_text(2);
      out.push_back(std::move(s));
    }
    for (auto& s : out) {
      const bool camera = s.kind == "camera";
      auto n = db_->prepare(camera ? "SELECT count(*), coalesce(sum(kept), 0), min(host_ns), max(host_ns) FROM frames "
                                     "WHERE device_id = ?"
                                   : "SELECT count(*), 0, min(host_ns), max(host_ns) FROM pressure_frames WHERE "
                                     "device_id = ?");
      n.bind_all(s.device_id);
      if (n.step()) {
        s.frames = std::uint64_t(n.column_int(0));
        s.in_video = std::uint64_t(n.column_int(1));
        const double span_s = double(n.column_int(3) - n.column_int(2)) / 1e9;
        if (s.frames > 1 && span_s > 0) s.mean_rate_hz = double(s.frames - 1) / span_s;
      }
      auto dr = db_->prepare("SELECT coalesce(sum(count), 0) FROM drops WHERE device_id = ?");
      dr.bind_all(s.device_id);
      if (dr.step()) s.dropped = std::uint64_t(dr.column_int(0));
      auto why = db_->prepare("SELECT reason, sum(count) FROM drops WHERE device_id = ? GROUP BY reason");
      why.bind_all(s.device_id);
      while (why.step()) s.dropped_by_reason[why.column_text(0)] = std::uint64_t(why.column_int(1));
      if (camera) {
        auto r = db_->prepare(
            "SELECT coalesce(reason, ''), count(*) FROM frames WHERE device_id = ? AND kept = 0 GROUP "
            "BY reason");
        r.bind_all(s.device_id);
        while (r.step()) s.not_kept[r.column_text(0)] = std::uint64_t(r.column_int(1));
        auto st = db_->prepare("SELECT status, count(*) FROM frames WHERE device_id = ? GROUP BY status");
        st.bind_all(s.device_id);
        while (st.step()) s.by_status[st.column_text(0)] = std::uint64_t(st.column_int(1));
      }
      auto ev = db_->prepare(
          "SELECT count(*) FROM events WHERE device_id = ? AND kind IN ('camera_lost', "
          "'sensel_unplugged')");
      ev.bind_all(s.device_id);
      if (ev.step()) s.connection_losses = std::uint64_t(ev.column_int(0));
    }
    return out;
  });
}

Result<std::vector<FrameTiming>> SessionReader::frame_timing(std::int64_t device_id) {
  return guarded(dir_, [&]() -> Result<std::vector<FrameTiming>> {
    const bool camera =
        std::any_of(cameras_.begin(), cameras_.end(), [&](const CameraInfo& c) { return c.device_id == device_id; });
    // Stores before version 6 have no chunk data, before version 7 no line levels.
    const char* chunks = info_.schema_version >= 7 ? "chunk_frame_counter, chunk_timestamp, chunk_exposure_us, "
                                                     "chunk_gain, chunk_line_status"
                         : info_.schema_version >= 6
                             ? "chunk_frame_counter, chunk_timestamp, chunk_exposure_us, chunk_gain, NULL"
                             : "NULL, NULL, NULL, NULL, NULL";
    auto q = db_->prepare(camera ? fmt::format("SELECT connection, sequence, host_ns, device_ns, mapped_ns, status = "
                                               "'good', kept, frame_id, 0, {} FROM frames WHERE device_id = ? ORDER "
                                               "BY host_ns",
                                               chunks)
                                 : std::string("SELECT connection, sequence, host_ns, device_ns, mapped_ns, 1, 0, 0, "
                                               "host_wait_ns, NULL, NULL, NULL, NULL, NULL FROM pressure_frames WHERE "
                                               "device_id = ? ORDER BY host_ns"));
    q.bind_all(device_id);
    std::vector<FrameTiming> out;
    const auto opt_real = [&q](int c) { return q.column_null(c) ? std::nullopt : std::optional(q.column_double(c)); };
    while (q.step())
      out.push_back({std::uint32_t(q.column_int(0)), std::uint64_t(q.column_int(1)), q.column_int(2), q.column_int(3),
                     opt_int(q, 4), q.column_int(5) != 0, q.column_int(6) != 0, std::uint64_t(q.column_int(7)),
                     q.column_int(8), opt_int(q, 9), opt_int(q, 10), opt_real(11), opt_real(12), opt_int(q, 13)});
    return out;
  });
}

Result<std::vector<PressurePayload>> SessionReader::pressure_payloads() {
  if (!pressure_device_) return std::vector<PressurePayload>{};
  return guarded(dir_, [&]() -> Result<std::vector<PressurePayload>> {
    auto q = db_->prepare(
        "SELECT connection, sequence, mapped_ns, payload FROM pressure_frames WHERE device_id = ? "
        "AND mapped_ns IS NOT NULL ORDER BY connection, sequence");
    q.bind_all(pressure_device_->device_id);
    std::vector<PressurePayload> out;
    while (q.step())
      out.push_back(
          {std::uint32_t(q.column_int(0)), std::uint64_t(q.column_int(1)), q.column_int(2), q.column_blob(3)});
    return out;
  });
}

Result<std::vector<PressureTotal>> SessionReader::pressure_totals() {
  if (!pressure_device_) return std::vector<PressureTotal>{};
  return guarded(dir_, [&]() -> Result<std::vector<PressureTotal>> {
    auto q = db_->prepare(
        "SELECT sequence, coalesce(mapped_ns, host_ns), grid_cols, grid_rows, counts, connection FROM "
        "pressure_frames WHERE device_id = ? AND counts IS NOT NULL ORDER BY "
        "coalesce(mapped_ns, host_ns)");
    q.bind_all(pressure_device_->device_id);
    std::vector<PressureTotal> out;
    while (q.step()) {
      const std::int64_t cols = q.column_int(2), rows = q.column_int(3);
      if (cols <= 0 || rows <= 0 || cols > kMaxGridSide || rows > kMaxGridSide)
        return Error{fmt::format("{}: pressure frame {} has an impossible grid {}x{}", dir_.string(), q.column_int(0),
                                 cols, rows)};
      auto counts = decompress_counts(q.column_blob(4), std::size_t(cols * rows));
      if (!counts)
        return Error{fmt::format("{}: pressure frame {}: {}", dir_.string(), q.column_int(0), counts.error().message)};
      double total = 0;
      for (auto c : counts.value()) total += c;
      out.push_back({std::uint64_t(q.column_int(0)), q.column_int(1), total, std::uint32_t(q.column_int(5))});
    }
    return out;
  });
}

Result<std::vector<SampleInfo>> SessionReader::sample_infos() {
  return guarded(dir_, [&]() -> Result<std::vector<SampleInfo>> {
    std::vector<SampleInfo> out;
    out.reserve(sample_ids_.size());
    std::map<std::uint64_t, std::size_t> position;
    auto q = db_->prepare(std::string(kSampleColumns) + "ORDER BY id");
    while (q.step()) {
      position[std::uint64_t(q.column_int(0))] = out.size();
      out.push_back(sample_row(q));
    }
    auto f = db_->prepare(
        "SELECT sf.sample_id, sf.device_id, sf.connection, sf.sequence, sf.offset_ns, f.kept, f.reason FROM "
        "sample_frames sf LEFT JOIN frames f USING (device_id, connection, sequence) ORDER BY sf.sample_id, "
        "sf.device_id");
    while (f.step()) {
      auto it = position.find(std::uint64_t(f.column_int(0)));
      if (it == position.end()) continue;
      out[it->second].cameras.push_back(
          {f.column_int(1), std::uint32_t(f.column_int(2)), std::uint64_t(f.column_int(3)), f.column_int(4),
           !f.column_null(5) && f.column_int(5) == 1, f.column_null(5) ? "no frame row" : text_or_empty(f, 6)});
    }
    return out;
  });
}

Result<std::vector<DropRecord>> SessionReader::drops() {
  return guarded(dir_, [&]() -> Result<std::vector<DropRecord>> {
    std::vector<DropRecord> out;
    auto q = db_->prepare(
        "SELECT device_id, connection, first_sequence, count, reason, host_ns FROM drops ORDER BY "
        "host_ns");
    while (q.step())
      out.push_back({q.column_int(0), std::uint32_t(q.column_int(1)), std::uint64_t(q.column_int(2)),
                     std::uint64_t(q.column_int(3)), text_or_empty(q, 4), q.column_int(5)});
    return out;
  });
}

Result<std::vector<ClockModelRecord>> SessionReader::clock_models() {
  return guarded(dir_, [&]() -> Result<std::vector<ClockModelRecord>> {
    std::vector<ClockModelRecord> out;
    auto q = db_->prepare(
        "SELECT device_id, host_ns, segment, x0_device_ns, offset_ns, skew, latency_ns, source, "
        "pairs, envelope_points, residual_p50_ns, residual_p99_ns FROM clock_models ORDER BY "
        "device_id, host_ns");
    while (q.step())
      out.push_back({q.column_int(0), q.column_int(1), int(q.column_int(2)), q.column_int(3), q.column_double(4),
                     q.column_double(5), q.column_int(6), text_or_empty(q, 7), std::uint64_t(q.column_int(8)),
                     std::uint64_t(q.column_int(9)), q.column_int(10), q.column_int(11)});
    return out;
  });
}

Result<std::vector<std::pair<std::string, std::uint64_t>>> SessionReader::timeline_counts() {
  return guarded(dir_, [&]() -> Result<std::vector<std::pair<std::string, std::uint64_t>>> {
    std::vector<std::pair<std::string, std::uint64_t>> out;
    auto q = db_->prepare("SELECT what, count FROM timeline_counts ORDER BY rowid");
    while (q.step()) out.emplace_back(q.column_text(0), std::uint64_t(q.column_int(1)));
    return out;
  });
}

}  // namespace pvcap
