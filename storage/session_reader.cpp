#include "storage/session_reader.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "storage/pressure_blob.h"
#include "storage/sqlite/database.h"
#include "storage/video_reader.h"

namespace pvcap {

namespace {
constexpr int kMaxGridSide = 1024;  // the Morph's grids are at most 185 x 105: anything bigger is damage
constexpr std::size_t kMaxOpenVideos = 16;
// A camera's segments are read in order: its current one and the one before stay open (a step
// back across the boundary), not every segment read so far (each holds ~10 MB of decoder and
// picture buffers, and an hour-long session has dozens per camera).
constexpr std::size_t kMaxOpenVideosPerCamera = 2;

// Everything below turns SQLite's exceptions into an Error naming the store.
template <typename F>
auto guarded(const std::filesystem::path& dir, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const sqlite::SqliteError& e) {
    return Error{fmt::format("{}: {}", dir.string(), e.what())};
  } catch (const std::exception& e) {
    return Error{fmt::format("{}: {}", dir.string(), e.what())};
  }
}

std::string text_or_empty(const sqlite::Statement& q, int col) { return q.column_null(col) ? "" : q.column_text(col); }
std::optional<std::int64_t> opt_int(const sqlite::Statement& q, int col) {
  return q.column_null(col) ? std::nullopt : std::optional<std::int64_t>(q.column_int(col));
}
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
        "SELECT d.id, d.name, d.serial, v.width, v.height FROM devices d JOIN video_files v ON v.device_id = d.id "
        "WHERE d.kind = 'camera' GROUP BY d.id ORDER BY d.id");
    while (cams.step()) {
      CameraInfo c{cams.column_int(0), cams.column_text(1), text_or_empty(cams, 2), int(cams.column_int(3)),
                   int(cams.column_int(4))};
      if (c.width <= 0 || c.height <= 0 || c.width > 16384 || c.height > 16384)
        return Error{
            fmt::format("{}: camera {} has an impossible size {}x{}", db_path.string(), c.name, c.width, c.height)};
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

Result<cv::Mat> SessionReader::camera_image(const SampleCamera& c, bool mosaic, std::string* bayer_format) {
  return guarded(dir_, [&]() -> Result<cv::Mat> {
    // Stores before version 5 have no checksums.
    auto q = db_->cached(fmt::format(
        "SELECT f.video_file_id, f.host_ns, v.path, f.video_pts_ms, {} FROM frames f JOIN video_files v ON v.id = "
        "f.video_file_id "
        "WHERE f.device_id = ? AND f.connection = ? AND f.sequence = ? AND f.kept = 1",
        info_.schema_version >= 5 ? "f.checksum" : "NULL"));
    q.bind_all(c.device_id, std::int64_t(c.connection), c.sequence);
    if (!q.step())
      return Error{fmt::format("{}: frame {} of device {} is not in a video", dir_.string(), c.sequence, c.device_id)};
    const std::int64_t file_id = q.column_int(0);
    const VideoTimestamp ts = video_timestamp(opt_int(q, 3), q.column_int(1), info_.started_host_ns);
    const std::string rel = q.column_text(2);
    const std::optional<std::int64_t> checksum = opt_int(q, 4);
    if (rel.empty() || rel.find("..") != std::string::npos || rel.front() == '/')
      return Error{fmt::format("{}: video path '{}' leaves the session folder", dir_.string(), rel)};
    // A viewer's read (half-size colour, nothing checked) skips a raw video's second green where
    // the video allows it (storage/video_reader.h); a read that wants the mosaic or its checksum
    // needs it whole. Which, depends on the read and the file alone, never on the reads before: the
    // same read gives the same image.
    if (view_videos_ && !mosaic && !(check_checksums_ && checksum))
      if (auto view = views_.image(file_id, rel, ts.ms, ts.tolerance_ms, image_size_)) return std::move(*view);
    const bool views_only = !mosaic && demosaic_ == Demosaic::HalfSize && !(check_checksums_ && checksum);
    auto it = videos_.find(file_id);
    if (it != videos_.end()) {
      const VideoReader& open = *it->second.reader;
      if (open.decodes_three_planes() != (views_only && open.can_decode_three_planes())) {
        videos_.erase(it);
        it = videos_.end();
      }
    }
    if (it == videos_.end()) {
      // The earliest of this camera's open segments goes first, then the earliest of all.
      std::size_t of_camera = 0;
      auto earliest_of_camera = videos_.end();
      for (auto v = videos_.begin(); v != videos_.end(); ++v)
        if (v->second.device_id == c.device_id && of_camera++ == 0) earliest_of_camera = v;
      if (of_camera >= kMaxOpenVideosPerCamera)
        videos_.erase(earliest_of_camera);
      else if (videos_.size() >= kMaxOpenVideos)
        videos_.erase(videos_.begin());
      VideoReader::Options options;
      options.half_size_colour_only = views_only;
      auto opened = VideoReader::open(dir_ / rel, options);
      if (!opened) return opened.error();
      it = videos_.emplace(file_id, OpenVideo{c.device_id, std::move(opened.value())}).first;
    }
    VideoReader& video = *it->second.reader;
    if (bayer_format) *bayer_format = video.bayer_format();
    video.set_demosaic(demosaic_);
    video.set_image_size(image_size_);
    cv::Mat bgr;
    auto found = mosaic ? video.read_raw_at(ts.ms, bgr, ts.tolerance_ms) : video.read_at(ts.ms, bgr, ts.tolerance_ms);
    if (!found) return found.error();
    if (!found.value())
      return Error{fmt::format("{}: no frame at {} ms in {}", dir_.string(), ts.ms, (dir_ / rel).string())};
    if (check_checksums_ && checksum) {
      const auto crc = video.decoded_picture_crc();
      if (crc && *crc != std::uint32_t(*checksum))
        return Error{fmt::format(
            "{}: frame {} (connection {}) of device {} at {} ms: its pixels are not the bytes the "
            "camera sent (checksum at capture {:08x}, stored picture {:08x})",
            (dir_ / rel).string(), c.sequence, c.connection, c.device_id, ts.ms, std::uint32_t(*checksum), *crc)};
    }
    return bgr;
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

void SessionReader::set_demosaic(Demosaic method) { demosaic_ = method; }

Result<cv::Mat> SessionReader::image(std::size_t i, std::size_t camera) { return one_image(i, camera, false); }
Result<cv::Mat> SessionReader::raw_image(std::size_t i, std::size_t camera) { return one_image(i, camera, true); }

Result<cv::Mat> SessionReader::image_region(std::size_t i, std::size_t camera, cv::Rect box) {
  if (camera < cameras_.size() && (box & cv::Rect(0, 0, cameras_[camera].width, cameras_[camera].height)) != box)
    return Error{fmt::format("{}: ({}, {}, {}, {}) is not inside camera {}'s {}x{} image", dir_.string(), box.x, box.y,
                             box.width, box.height, cameras_[camera].name, cameras_[camera].width,
                             cameras_[camera].height)};
  if (demosaic_ == Demosaic::Bilinear && image_size_ == cv::Size() && !view_videos_) {
    std::string format;
    auto mosaic = one_image(i, camera, true, &format);  // an Error for a colour video: cut below
    if (mosaic && mosaic.value().empty()) return cv::Mat();  // the sample has no stored frame of it
    if (mosaic && !format.empty() && (box & cv::Rect({0, 0}, mosaic.value().size())) == box) {
      // Bilinear demosaicing reads each pixel's 3x3 neighbours: a margin of 2 from an even corner
      // (the pattern's phase kept) gives the box the whole image's pixels.
      const cv::Mat& m = mosaic.value();
      const int x0 = std::max(0, box.x - 2) & ~1, y0 = std::max(0, box.y - 2) & ~1;
      const int x1 = std::min(m.cols, box.br().x + 2), y1 = std::min(m.rows, box.br().y + 2);
      cv::Mat bgr;
      if (Status d = debayer(m(cv::Rect(x0, y0, x1 - x0, y1 - y0)), format, demosaic_, bgr); !d.ok())
        return d.error();
      return bgr(cv::Rect(box.x - x0, box.y - y0, box.width, box.height)).clone();
    }
  }
  auto whole = image(i, camera);
  if (!whole || whole.value().empty()) return whole;
  if ((box & cv::Rect({0, 0}, whole.value().size())) != box)
    return Error{fmt::format("{}: ({}, {}, {}, {}) is not inside the {}x{} image", dir_.string(), box.x, box.y,
                             box.width, box.height, whole.value().cols, whole.value().rows)};
  return whole.value()(box).clone();
}

Result<cv::Mat> SessionReader::one_image(std::size_t i, std::size_t camera, bool mosaic, std::string* bayer_format) {
  if (camera >= cameras_.size())
    return Error{fmt::format("{}: no camera {} (the session has {})", dir_.string(), camera, cameras_.size())};
  auto info = sample_info(i);
  if (!info) return info.error();
  for (const auto& c : info.value().cameras)
    if (c.device_id == cameras_[camera].device_id)
      return c.in_video ? camera_image(c, mosaic, bayer_format) : Result<cv::Mat>(cv::Mat());
  return cv::Mat();
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
    auto q = db_->prepare(camera ? "SELECT connection, sequence, host_ns, device_ns, mapped_ns, status = 'good', kept, "
                                   "frame_id, 0 FROM frames WHERE device_id = ? ORDER BY host_ns"
                                 : "SELECT connection, sequence, host_ns, device_ns, mapped_ns, 1, 0, 0, host_wait_ns "
                                   "FROM pressure_frames WHERE device_id = ? ORDER BY host_ns");
    q.bind_all(device_id);
    std::vector<FrameTiming> out;
    while (q.step())
      out.push_back({std::uint32_t(q.column_int(0)), std::uint64_t(q.column_int(1)), q.column_int(2), q.column_int(3),
                     opt_int(q, 4), q.column_int(5) != 0, q.column_int(6) != 0, std::uint64_t(q.column_int(7)),
                     q.column_int(8)});
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
