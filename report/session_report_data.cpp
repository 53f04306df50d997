#include "report/session_report_data.h"

#include "report/camera_state.h"
#include "report/ptp_time.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "calib/press_check.h"
#include "calib/projection.h"
#include "calib/recorded_calibration.h"
#include "calib/rig_calibration.h"
#include "codec/image_files.h"
#include "codec/sensel_units.h"
#include "core/side_by_side.h"
#include "core/statistics.h"
#include "core/time.h"
#include "report/press_windows.h"
#include "report/report_numbers.h"
#include "report/takes_sections.h"
#include "report/sync_self_check.h"
#include "storage/index/session_reader.h"

namespace pvcap::report {

namespace {

// A reading the store gave no answer to because the disk failed it (not because the store lacks it,
// or holds it damaged): the report fails naming the file, never leaves it out.
template <typename T>
bool readable(const Result<T>& r) {
  if (!r && r.error().disk_failed) throw UserError(r.error().message);
  return r.ok();
}

using nlohmann::json;


// Counts of `values` in `bins` equal bins over [lo, hi), with the ones below and above counted apart.
json histogram(const std::vector<double>& values, double lo, double hi, int bins) {
  std::vector<std::uint64_t> counts(std::size_t(bins), 0);
  std::uint64_t below = 0, above = 0;
  const double width = (hi - lo) / bins;
  for (double v : values) {
    if (v < lo)
      ++below;
    else if (v >= hi)
      ++above;
    else
      ++counts[std::min(std::size_t(bins - 1), std::size_t((v - lo) / width))];
  }
  return {{"lo", lo}, {"hi", hi}, {"counts", counts}, {"below", below}, {"above", above}};
}

// A long series thinned for plotting: per time bin its lowest and highest value, so a spike survives.
json thin_minmax(const std::vector<std::pair<double, double>>& series, std::size_t max_bins) {
  json out = json::array();
  if (series.empty()) return out;
  if (series.size() <= 2 * max_bins) {
    for (const auto& [t, v] : series) out.push_back({round_to(t, 1e-3), round_to(v, 1e-3)});
    return out;
  }
  const double t0 = series.front().first, t1 = series.back().first;
  const double width = std::max(1e-9, (t1 - t0) / double(max_bins));
  std::size_t i = 0;
  for (std::size_t b = 0; b < max_bins && i < series.size(); ++b) {
    const double end = t0 + width * double(b + 1);
    std::optional<std::pair<double, double>> lo, hi;
    for (; i < series.size() && (series[i].first < end || b + 1 == max_bins); ++i) {
      if (!lo || series[i].second < lo->second) lo = series[i];
      if (!hi || series[i].second > hi->second) hi = series[i];
    }
    if (!lo) continue;
    const auto& first = lo->first <= hi->first ? *lo : *hi;
    const auto& second = lo->first <= hi->first ? *hi : *lo;
    out.push_back({round_to(first.first, 1e-3), round_to(first.second, 1e-3)});
    if (second != first) out.push_back({round_to(second.first, 1e-3), round_to(second.second, 1e-3)});
  }
  return out;
}

std::string base64(const std::vector<std::uint8_t>& bytes) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    const std::uint32_t n = std::uint32_t(bytes[i]) << 16 |
                            (i + 1 < bytes.size() ? std::uint32_t(bytes[i + 1]) << 8 : 0) |
                            (i + 2 < bytes.size() ? bytes[i + 2] : 0);
    out += k[n >> 18 & 63];
    out += k[n >> 12 & 63];
    out += i + 1 < bytes.size() ? k[n >> 6 & 63] : '=';
    out += i + 2 < bytes.size() ? k[n & 63] : '=';
  }
  return out;
}

std::string jpeg_data_uri(const cv::Mat& bgr, int width) {
  cv::Mat small;
  cv::resize(bgr, small, {width, std::max(1, bgr.rows * width / std::max(1, bgr.cols))}, 0, 0, cv::INTER_AREA);
  auto jpeg = encode_jpeg(small, 80);
  if (!jpeg) throw UserError(fmt::format("the report's camera view: {}", jpeg.error().message));
  return "data:image/jpeg;base64," + base64(jpeg.value());
}

// Captured and lost, per stream, with the identities that must hold between the store's tables.
json streams_section(SessionReader& r) {
  auto stats = r.stream_statistics();
  if (!stats) throw UserError(stats.error().message);
  json out = json::array();
  for (const auto& s : stats.value()) {
    std::uint64_t by_status = 0, not_kept = 0;
    for (const auto& [k, n] : s.by_status) by_status += n;
    for (const auto& [k, n] : s.not_kept) not_kept += n;
    json j = {{"name", s.name},
              {"kind", s.kind},
              {"frames", s.frames},
              {"not_received", s.dropped},
              {"not_received_by_reason", s.dropped_by_reason},
              {"connection_losses", s.connection_losses},
              {"mean_rate_hz", round_to(s.mean_rate_hz, 1e-3)}};
    if (s.kind == "camera") {
      j["by_status"] = s.by_status;
      j["in_video"] = s.in_video;
      j["not_kept"] = s.not_kept;
      // Every frames row has one status, and is either in a video or not kept for a reason.
      j["reconciles"] = by_status == s.frames && s.in_video + not_kept == s.frames;
    } else {
      j["reconciles"] = true;
    }
    out.push_back(std::move(j));
  }
  return out;
}

json intervals_section(SessionReader& r, std::int64_t start_ns) {
  json out = json::array();
  auto drops = r.drops();
  if (!drops) throw UserError(drops.error().message);
  std::vector<std::pair<std::int64_t, std::string>> devices;
  for (const auto& c : r.cameras()) devices.emplace_back(c.device_id, c.name);
  if (r.pressure_device()) devices.emplace_back(r.pressure_device()->device_id, r.pressure_device()->name);
  for (const auto& [id, name] : devices) {
    auto timing = r.frame_timing(id);
    if (!timing) throw UserError(timing.error().message);
    // On the session clock where mapped (the device's own spacing), by arrival otherwise.
    std::vector<std::pair<std::uint32_t, std::int64_t>> times;
    for (const auto& f : timing.value()) times.emplace_back(f.connection, f.mapped_ns.value_or(f.host_ns));
    std::sort(times.begin(), times.end());
    std::vector<std::pair<double, double>> series;
    std::vector<double> intervals;
    for (std::size_t i = 1; i < times.size(); ++i) {
      if (times[i].first != times[i - 1].first) continue;  // a reconnection is not an interval
      const double ms = double(times[i].second - times[i - 1].second) / 1e6;
      series.emplace_back(seconds(times[i].second, start_ns), ms);
      intervals.push_back(ms);
    }
    std::sort(series.begin(), series.end());
    const double median = percentile(intervals, 0.5);
    json drop_marks = json::array();
    std::uint64_t dropped = 0;
    for (const auto& d : drops.value())
      if (d.device_id == id) {
        drop_marks.push_back({round_to(seconds(d.host_ns, start_ns), 1e-3), d.count});
        dropped += d.count;
      }
    out.push_back(
        {{"name", name},
         {"intervals", intervals.size()},
         {"median_ms", round_to(median, 1e-3)},
         {"p99_ms", round_to(percentile(intervals, 0.99), 1e-3)},
         {"max_ms", round_to(intervals.empty() ? 0 : *std::max_element(intervals.begin(), intervals.end()), 1e-3)},
         {"series", thin_minmax(series, 600)},
         {"histogram", histogram(intervals, 0, std::max(1.0, 3 * median), 60)},
         {"drops", drop_marks},
         {"not_received", dropped}});
  }
  return out;
}

json clocks_section(SessionReader& r, std::int64_t start_ns) {
  auto rows = r.clock_models();
  if (!rows) throw UserError(rows.error().message);
  std::map<std::int64_t, std::string> names;
  for (const auto& c : r.cameras()) names[c.device_id] = c.name;
  if (r.pressure_device()) names[r.pressure_device()->device_id] = r.pressure_device()->name;
  std::map<std::int64_t, std::vector<const ClockModelRecord*>> by_device;
  for (const auto& m : rows.value()) by_device[m.device_id].push_back(&m);
  json out = json::array();
  for (const auto& [id, list] : by_device) {
    json series = json::array();
    std::set<int> segments;
    std::vector<double> p99;
    const std::size_t stride = std::max<std::size_t>(1, list.size() / 600);
    // The offset as it moved: relative to the segment's first fit, evaluated at the fit's own time.
    std::map<int, double> first_offset;
    for (std::size_t i = 0; i < list.size(); ++i) {
      const ClockModelRecord& m = *list[i];
      segments.insert(m.segment);
      p99.push_back(double(m.residual_p99_ns) / 1e3);
      // host - device at the fit's own instant: mapped = device + offset + skew (device - x0) - latency.
      const double device_now = double(m.host_ns) - m.offset_ns;
      const double offset_now = m.offset_ns + m.skew * (device_now - double(m.x0_device_ns));
      if (!first_offset.count(m.segment)) first_offset[m.segment] = offset_now;
      if (i % stride == 0 || i + 1 == list.size())
        series.push_back({{"t_s", round_to(seconds(m.host_ns, start_ns), 1e-3)},
                          {"segment", m.segment},
                          {"offset_change_us", round_to((offset_now - first_offset[m.segment]) / 1e3, 1e-3)},
                          {"device_fast_ppm", round_to(-m.skew * 1e6, 1e-3)},
                          {"residual_p50_us", round_to(double(m.residual_p50_ns) / 1e3, 1e-3)},
                          {"residual_p99_us", round_to(double(m.residual_p99_ns) / 1e3, 1e-3)}});
    }
    const ClockModelRecord& last = *list.back();
    out.push_back({{"name", names.count(id) ? names[id] : fmt::format("device {}", id)},
                   {"source", last.source},
                   {"segments", segments.size()},
                   {"resets", segments.empty() ? 0 : segments.size() - 1},
                   // What is added to a stamp's fitted time: half a camera's exposure (its stamp marks
                   // the exposure's start), less a latency the rig file declares for arrival clocks.
                   {"stamp_to_instant_ms", double(-last.latency_ns) / 1e6},
                   // The fit's skew is host per device time: a device clock running fast has it negative.
                   {"device_fast_ppm", round_to(-last.skew * 1e6, 1e-3)},
                   {"pairs", last.pairs},
                   {"residual_p99_us_median", round_to(percentile(p99, 0.5), 1e-3)},
                   {"residual_p99_us_max", round_to(p99.empty() ? 0 : *std::max_element(p99.begin(), p99.end()), 1e-3)},
                   {"series", series}});
  }
  return out;
}

json pairing_section(const std::vector<SampleInfo>& samples, std::size_t n_cameras) {
  std::vector<double> offsets, spans;
  std::uint64_t unpaired = 0, missing_camera = 0, ties = 0;
  for (const auto& s : samples) {
    spans.push_back(double(s.span_ns) / 1e6);
    if (s.cameras.size() < n_cameras) ++missing_camera;
    if (!s.pressure) {
      ++unpaired;
      continue;
    }
    offsets.push_back(double(s.pressure->offset_ns) / 1e6);
    // Either neighbour could have been paired: they lie equally near the sample's instant.
    if (s.before && s.after && std::abs(-s.before->offset_ns - s.after->offset_ns) < 100'000) ++ties;
  }
  std::vector<double> abs_offsets;
  for (double v : offsets) abs_offsets.push_back(std::abs(v));
  return {{"samples", samples.size()},
          {"paired", offsets.size()},
          {"unpaired", unpaired},
          {"missing_a_camera", missing_camera},
          {"ties", ties},
          {"abs_offset_ms_p50", round_to(percentile(abs_offsets, 0.5), 1e-3)},
          {"abs_offset_ms_p99", round_to(percentile(abs_offsets, 0.99), 1e-3)},
          {"offset_histogram_ms", histogram(offsets, -6, 6, 48)},
          {"camera_span_ms_p50", round_to(percentile(spans, 0.5), 1e-3)},
          {"camera_span_ms_max", round_to(spans.empty() ? 0 : *std::max_element(spans.begin(), spans.end()), 1e-3)}};
}

// Each camera's calibration measurements as the session records them, and the pose in force.
std::vector<std::optional<calib::CameraCalibration>> calibration_in_force(SessionReader& r, json& section) {
  auto rows = r.calibrations();
  if (!rows) throw UserError(rows.error().message);
  auto in_force = calib::pad_calibrations(r);
  if (!in_force) throw UserError(in_force.error().message);
  section = json::array();
  for (std::size_t c = 0; c < r.cameras().size(); ++c) {
    json cam = {{"name", r.cameras()[c].name}, {"measurements", json::array()}};
    for (const auto& row : rows.value()) {
      if (row.device_id != r.cameras()[c].device_id) continue;
      json m = {{"method", row.method}, {"created_utc", format_utc(row.created_wall_ns)}};
      if (row.rms_px) m["rms_px"] = round_to(*row.rms_px, 1e-4);
      if (row.rms_mm) m["rms_mm"] = round_to(*row.rms_mm, 1e-4);
      cam["measurements"].push_back(std::move(m));
    }
    cam["pad_calibrated"] = in_force.value()[c].has_value();
    section.push_back(std::move(cam));
  }
  return in_force.value();
}

// The pixels near the contact in one camera: a square of 30 mm on the pad around `centre_cells`.
std::optional<cv::Rect> contact_roi(const calib::CameraModel& m, const calib::PadLayout& pad, cv::Point2d centre_cells,
                                    cv::Size image) {
  const cv::Point2d c = pad.cell_to_mm(centre_cells);
  std::vector<cv::Point2f> corners;
  for (double dx : {-15.0, 15.0})
    for (double dy : {-15.0, 15.0}) {
      const cv::Point2d p = m.project({c.x + dx, c.y + dy, 0.0});
      corners.emplace_back(float(p.x), float(p.y));
    }
  const cv::Rect roi = cv::boundingRect(corners) & cv::Rect({0, 0}, image);
  if (roi.width < 4 || roi.height < 4) return std::nullopt;
  return roi;
}

// One camera's image change near the contact in each of `presses` (its window and pressure; the
// contact's centroid on the pad in `centroids`), read through `r`, a reader of this thread alone.
std::vector<PressSignals> camera_signals(SessionReader& r, std::size_t c, const calib::CameraCalibration& cal,
                                         const calib::PadLayout& pad, const std::vector<SampleInfo>& samples,
                                         const std::vector<std::pair<PressWindow, PressSignals>>& presses,
                                         const std::vector<cv::Point2d>& centroids,
                                         const std::function<void()>& press_done) {
  std::vector<PressSignals> out;
  const CameraInfo& camera = r.cameras()[c];
  for (std::size_t k = 0; k < presses.size(); ++k) {
    const auto& [w, base] = presses[k];
    const auto first = std::lower_bound(samples.begin(), samples.end(), w.from_ns,
                                        [](const SampleInfo& s, std::int64_t t) { return s.t_ns < t; });
    const auto roi = contact_roi(cal.model, pad, centroids[k], {camera.width, camera.height});
    if (roi) {
      PressSignals s{base.pressure, {}};
      cv::Mat reference;
      for (auto it = first; it != samples.end() && it->t_ns <= w.to_ns; ++it) {
        const auto frame = std::find_if(it->cameras.begin(), it->cameras.end(),
                                        [&](const SampleCamera& f) { return f.device_id == camera.device_id; });
        if (frame == it->cameras.end() || !frame->in_video) continue;
        auto image = r.image(std::size_t(it - samples.begin()), c);
        if (!image && image.error().disk_failed) throw UserError(image.error().message);  // not a damaged frame
        if (!image || image.value().empty()) continue;
        cv::Mat patch;
        image.value()(*roi).convertTo(patch, CV_32F);
        if (reference.empty()) reference = patch.clone();
        cv::Mat diff;
        cv::absdiff(patch, reference, diff);
        // Pixels that changed by more than 10 levels per channel on average: the fingertip's
        // footprint, robust to the codec's small errors (a mean difference picks them up).
        cv::Mat summed;
        cv::transform(diff, summed, cv::Matx13f(1, 1, 1));
        s.image.push_back({it->t_ns + frame->offset_ns, double(cv::countNonZero(summed > 30.0))});
      }
      out.push_back(std::move(s));
    }
    press_done();
  }
  return out;
}

json self_check_section(const std::filesystem::path& dir, SessionReader& r,
                        const std::vector<std::optional<calib::CameraCalibration>>& cal, const calib::PadLayout& pad,
                        const std::vector<SampleInfo>& samples, const std::vector<PressureTotal>& totals,
                        const ReportOptions& o) {
  json out = {{"cameras", json::array()}};
  out["method"] =
      "image change near the contact against total pressure on the presses' flanks: the offset at which "
      "one curve fits the rising and the falling edges; uncertainty: jackknife over presses (1 standard "
      "error)";
  const PressFinding found = find_presses(totals);
  out["presses_found"] = found.presses;
  out["presses_isolated"] = found.isolated.size();
  std::vector<PressWindow> use = found.isolated;
  if (int(use.size()) > o.max_self_check_presses) {
    std::vector<PressWindow> some;
    for (int k = 0; k < o.max_self_check_presses; ++k)
      some.push_back(use[std::size_t(k) * use.size() / std::size_t(o.max_self_check_presses)]);
    use = std::move(some);
  }
  out["presses_used"] = use.size();
  // Each press with a contact: its pressure (from the totals) and the contact's centroid.
  std::vector<std::pair<PressWindow, PressSignals>> presses;
  std::vector<cv::Point2d> centroids;
  for (const PressWindow& w : use) {
    auto peak = r.pressure_frame(w.peak_sequence, w.peak_connection);
    if (!readable(peak)) continue;
    const auto centroid =
        calib::pressure_centroid(peak.value().image(), peak.value().grid_xscale, peak.value().grid_yscale);
    if (!centroid) continue;
    PressSignals base;
    for (const auto& t : totals)
      if (t.t_ns >= w.from_ns && t.t_ns <= w.to_ns) base.pressure.push_back({t.t_ns, t.total_counts});
    presses.emplace_back(w, std::move(base));
    centroids.push_back(*centroid);
  }
  // Per camera, the image change around each press: decoding the frames is the self-check's work,
  // and a camera's is its own, so the cameras are read side by side, each through its own reader
  // (a reader decodes with state of its own), as the intrinsics are (calib/session_calibration.cpp).
  std::vector<std::vector<PressSignals>> per_camera(r.cameras().size());
  std::vector<std::size_t> cameras;
  for (std::size_t c = 0; c < r.cameras().size(); ++c)
    if (cal[c]) cameras.push_back(c);
  std::mutex mutex;  // guards done and the progress callback
  std::size_t done = 0;
  const std::size_t total = cameras.size() * presses.size();
  auto press_done = [&] {
    const std::lock_guard lock(mutex);
    if (o.progress) o.progress("sync self-check", ++done, total);
  };
  std::vector<std::unique_ptr<SessionReader>> readers(cameras.size());  // the workers' after the first
  run_side_by_side(cameras.size(), cameras.size(), [&](std::size_t i, std::size_t worker) {
    if (worker > 0 && !readers[worker]) {
      auto opened = SessionReader::open(dir);
      if (!opened) throw UserError(opened.error().message);
      readers[worker] = std::move(opened.value());
    }
    SessionReader& own = worker == 0 ? r : *readers[worker];
    per_camera[cameras[i]] =
        camera_signals(own, cameras[i], *cal[cameras[i]], pad, samples, presses, centroids, press_done);
  });
  for (std::size_t c = 0; c < r.cameras().size(); ++c) {
    json j = {{"name", r.cameras()[c].name}};
    if (!cal[c]) {
      j["offset_ms"] = nullptr;
      j["uncertainty_ms"] = nullptr;
      j["presses"] = 0;
      j["verdict"] =
          "no pad calibration in the session: the contact cannot be found in this camera's image "
          "(`pvcap calibrate pad`)";
    } else {
      const OffsetEstimate e = estimate_offset(per_camera[c]);
      j["offset_ms"] = e.offset_ms ? json(round_to(*e.offset_ms, 1e-3)) : json(nullptr);
      j["uncertainty_ms"] = e.uncertainty_ms ? json(round_to(*e.uncertainty_ms, 1e-3)) : json(nullptr);
      j["presses"] = e.presses_used;
      j["presses_rejected"] = e.presses_rejected;
      j["verdict"] = e.verdict;
    }
    out["cameras"].push_back(std::move(j));
  }
  return out;
}

// A pressure-overlay frame per camera: the sample at the session's strongest press (or the nearest
// one holding that camera's frame, when its frame is missing there).
void add_thumbnails(SessionReader& r, json& calibration,
                    const std::vector<std::optional<calib::CameraCalibration>>& cal, const calib::PadLayout& pad,
                    const std::vector<PressureTotal>& totals) {
  if (totals.empty() || r.sample_count() == 0) return;
  const auto peak = std::max_element(totals.begin(), totals.end(), [](const PressureTotal& a, const PressureTotal& b) {
    return a.total_counts < b.total_counts;
  });
  auto centre = r.sample_at(peak->t_ns);
  if (!readable(centre)) return;
  for (std::size_t c = 0; c < r.cameras().size() && c < calibration.size(); ++c) {
    for (int d : {0, -1, 1, -2, 2, -3, 3}) {
      const std::int64_t i = std::int64_t(centre.value()) + d;
      if (i < 0 || i >= std::int64_t(r.sample_count())) continue;
      // Only this camera's picture: a whole sample would decode every camera's, four times over.
      auto info = r.sample_info(std::size_t(i));
      if (!readable(info) || !info.value().pressure) continue;
      auto decoded = r.image(std::size_t(i), c);
      if (!decoded && decoded.error().disk_failed) throw UserError(decoded.error().message);
      if (!decoded || decoded.value().empty()) continue;
      auto pressure = r.pressure_frame(info.value().pressure->sequence, info.value().pressure->connection);
      if (!readable(pressure)) continue;
      const PressureFrame& p = pressure.value();
      const cv::Mat& image = decoded.value();
      cv::Mat shown = image;
      if (cal[c] && cal[c]->model.image_size == image.size()) {
        const sensel::Grid grid{p.grid_cols, p.grid_rows, p.grid_xscale, p.grid_yscale};
        const std::vector<float> up = sensel::upsample(p.counts, grid);
        const cv::Mat counts(grid.out_rows(), grid.out_cols(), CV_32F, const_cast<float*>(up.data()));
        double top = 0;
        cv::minMaxLoc(counts, nullptr, &top);
        shown = calib::overlay_pressure(image, calib::PressureProjector(cal[c]->model, pad).project(counts), top);
      }
      calibration[c]["thumbnail"] = jpeg_data_uri(shown, 480);
      calibration[c]["thumbnail_sample"] = i;
      calibration[c]["thumbnail_overlay"] = cal[c].has_value();
      break;
    }
  }
}

}  // namespace

Result<json> build_report(const std::filesystem::path& dir, const ReportOptions& o) {
  auto opened = SessionReader::open(dir);
  if (!opened) return opened.error();
  SessionReader& r = *opened.value();
  try {
    const SessionInfo& info = r.info();
    const std::int64_t start = info.started_host_ns;
    json j;
    j["report_format"] = 1;
    json session = {{"folder", std::filesystem::absolute(dir).lexically_normal().string()},
                    {"rig", info.rig_name},
                    {"started_utc", format_utc(info.started_wall_ns)},
                    {"ended_cleanly", info.ended_host_ns.has_value()},
                    {"end_reason", info.end_reason},
                    {"pvcap_version", info.pvcap_version},
                    {"simulated", info.simulated}};
    if (info.ended_host_ns) session["duration_s"] = round_to(seconds(*info.ended_host_ns, start), 1e-3);
    if (info.participant)
      session["participant"] = {{"pseudonym", info.participant->pseudonym},
                                {"skin_tone", info.participant->skin_tone},
                                {"hand_order", info.participant->hand_order}};
    if (info.conditions)
      session["conditions"] = {{"lighting", info.conditions->lighting},
                               {"sensor_overlay", info.conditions->sensor_overlay}};
    j["session"] = session;
    if (o.progress) o.progress("reading the store", 0, 5);
    j["streams"] = streams_section(r);
    j["intervals"] = intervals_section(r, start);
    if (o.progress) o.progress("reading the store", 2, 5);
    j["clocks"] = clocks_section(r, start);
    auto samples = r.sample_infos();
    if (!samples) return samples.error();
    j["pairing"] = pairing_section(samples.value(), r.cameras().size());
    auto counts = r.timeline_counts();
    if (!counts) return counts.error();
    for (const auto& [what, n] : counts.value()) j["pairing"]["timeline_counts"][what] = n;
    if (o.progress) o.progress("reading the store", 4, 5);
    j["protocol"] = protocol_section(dir, start);
    if (auto lighting = lighting_section(r, start)) j["lighting"] = *lighting;
    {
      auto settings = r.camera_settings();
      if (!settings) return settings.error();
      std::vector<CameraBag> previous;
      const auto previous_dir = previous_session_of_rig(dir);
      if (previous_dir)  // a previous session that cannot be read is compared with nothing
        if (auto p = SessionReader::open(*previous_dir))
          if (auto s = p.value()->camera_settings()) previous = camera_bags(s.value());
      j["camera_state"] = camera_state_section(
          camera_bags(settings.value()), previous_dir ? std::optional(previous_dir->filename().string()) : std::nullopt,
          previous);
    }
    auto events = r.events();
    if (!events) return events.error();
    {
      std::map<std::int64_t, std::string> names;
      for (const auto& c : r.cameras()) names[c.device_id] = c.name;
      if (auto ptp = ptp_time_section(events.value(), start, names)) j["ptp_time"] = *ptp;
    }
    j["events"] = json::array();
    for (const auto& e : events.value())
      if (!is_ptp_reading(e))  // one a second: summed up in ptp_time
        j["events"].push_back(
          {{"t_s", round_to(seconds(e.host_ns, start), 1e-3)}, {"kind", e.kind}, {"message", e.message}});
    json calibration;
    const calib::PadLayout pad = calib::default_pad_layout();
    const auto cal = calibration_in_force(r, calibration);
    auto totals = r.pressure_totals();
    if (!totals) return totals.error();
    if (o.progress) o.progress("reading the store", 5, 5);
    if (o.thumbnails) add_thumbnails(r, calibration, cal, pad, totals.value());
    j["calibration"] = calibration;
    if (o.self_check) j["self_check"] = self_check_section(dir, r, cal, pad, samples.value(), totals.value(), o);
    return j;
  } catch (const UserError& e) {
    return Error{e.what()};
  }
}

}  // namespace pvcap::report
