#include "calib/session_calibration.h"

#include <algorithm>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "calib/board_views_file.h"
#include "calib/charuco.h"
#include "calib/pad_calibration.h"
#include "calib/press_check.h"
#include "calib/rig_calibration.h"
#include "codec/image_files.h"
#include "core/result.h"
#include "core/side_by_side.h"
#include "core/time.h"
#include "storage/index/session_index.h"
#include "storage/index/session_reader.h"

namespace pvcap::calib {
namespace {

// Targets the reference check holds a calibration to (issue: calibration).
constexpr double kFocalTolerance = 0.005, kPrincipalTolerancePx = 2.0;
constexpr double kCornerMedianPx = 0.3, kCornerMaxPx = 1.0;

// The sinks' calls, each a no-op when the caller gave none.
void say(const CalibrationSinks& out, const std::string& text) {
  if (out.say) out.say(text);
}
void warn(const CalibrationSinks& out, const std::string& line) {
  if (out.warn) out.warn(line);
}
void progress(const CalibrationSinks& out, const std::string& what, std::size_t done, std::size_t total) {
  if (out.progress) out.progress(what, done, total);
}

std::unique_ptr<SessionReader> open_session(const std::filesystem::path& dir) {
  auto r = SessionReader::open(dir);
  if (!r) throw UserError(r.error().message);
  return std::move(r.value());
}

// Up to `wanted` sample indices spread evenly over the session.
std::vector<std::size_t> spread(std::size_t count, std::size_t wanted) {
  std::vector<std::size_t> out;
  if (count == 0) return out;
  wanted = std::min(wanted, count);
  for (std::size_t k = 0; k < wanted; ++k) out.push_back(k * count / wanted);
  return out;
}

// The samples a command looks at: --frames of them (or `by_default`) spread over the session.
std::vector<std::size_t> samples_to_read(const SessionReader& session, const SessionCalibrationOptions& o,
                                         std::size_t by_default) {
  auto samples = spread(session.sample_count(), o.frames > 0 ? std::size_t(o.frames) : by_default);
  if (samples.empty()) throw UserError(fmt::format("{}: the session has no samples", o.session.string()));
  return samples;
}

// Hands camera `c`'s stored image of each sample to `use` (samples without one are skipped),
// with progress on the terminal.
template <typename Use>
void for_each_image(SessionReader& session, std::size_t c, const std::vector<std::size_t>& samples,
                    const std::string& what, const CalibrationSinks& out, Use use) {
  std::size_t done = 0;
  for (std::size_t i : samples) {
    auto image = session.image(i, c);
    if (!image) throw UserError(image.error().message);
    if (!image.value().empty()) use(image.value());
    progress(out, session.cameras()[c].name + ": " + what, ++done, samples.size());
  }
}

const ReferenceCamera& reference_camera(const ReferenceCalibration& reference, const std::string& name) {
  const ReferenceCamera* t = reference.camera(name);
  if (!t) throw UserError(fmt::format("camera {} is not in {}", name, reference.label));
  return *t;
}

// Records `c`'s latest measurement in the session's calibrations table.
void add_to_session(const std::filesystem::path& session, const CameraInfo& camera, const calib::CameraCalibration& c,
                    const calib::MeasuredBy& m, const std::filesystem::path& file) {
  CalibrationRecord r;
  r.device_id = camera.device_id;
  r.created_wall_ns = m.created_wall_ns;
  r.method = m.method;
  const cv::Matx33d h = c.cells_to_ideal.value_or(cv::Matx33d::zeros());
  r.homography_json = nlohmann::json(std::vector<double>(h.val, h.val + 9)).dump();
  r.rms_px = m.rms_px;
  r.rms_mm = m.rms_mm;
  nlohmann::json details = nlohmann::json(c);
  details["calibration_file"] = std::filesystem::absolute(file).string();
  r.details_json = details.dump();
  try {
    auto index = SessionIndex::open_for_update(session / "session.db");
    index.add_calibration(r);
  } catch (const std::exception& e) {
    throw UserError(
        fmt::format("{}: could not add the calibration to the session: {} (the calibration file {} has "
                    "it)",
                    session.string(), e.what(), file.string()));
  }
}

calib::RigCalibration load_or_new(const std::filesystem::path& file, const SessionReader& session) {
  calib::RigCalibration cal;
  if (std::filesystem::exists(file)) {
    auto loaded = calib::load_rig_calibration(file);
    if (!loaded) throw UserError(loaded.error().message);
    cal = std::move(loaded.value());
  }
  if (cal.rig.empty()) cal.rig = session.info().rig_name;
  return cal;
}

std::filesystem::path calibration_file(const SessionCalibrationOptions& o) {
  return o.calibration.empty() ? o.session / "calibration.yaml" : o.calibration;
}

std::string fmt_point(cv::Point2d p) { return fmt::format("({:.1f}, {:.1f})", p.x, p.y); }

// What intrinsics and pad work on, camera by camera: the session, its calibration file (loaded, or
// new), the samples to look at, the reference when given, and the outcome so far.
struct CalibrationRun {
  std::unique_ptr<SessionReader> session;
  std::filesystem::path file;
  calib::RigCalibration cal;
  std::vector<std::size_t> samples;
  const std::optional<ReferenceCalibration>& reference;
  const CalibrationSinks& out;
  std::vector<std::string> failed;
  bool within_targets = true;

  CalibrationRun(const SessionCalibrationOptions& o, std::size_t frames_by_default)
      : session(open_session(o.session)),
        file(calibration_file(o)),
        cal(load_or_new(file, *session)),
        samples(samples_to_read(*session, o, frames_by_default)),
        reference(o.reference),
        out(o.sinks) {}

  // What succeeded is saved whatever failed; the failures are named; false when any camera failed
  // or missed its target against the reference.
  bool save_and_report(const std::string& next) const {
    if (Status s = calib::save_rig_calibration(file, cal); !s.ok()) throw UserError(s.error().message);
    say(out, fmt::format("wrote {}{}\n", file.string(), next));
    for (const auto& f : failed) warn(out, f);
    return failed.empty() && within_targets;
  }
};

}  // namespace

const ReferenceCamera* ReferenceCalibration::camera(const std::string& name) const {
  for (const auto& c : cameras)
    if (c.name == name) return &c;
  return nullptr;
}

ReferenceCalibration reference_from(const RigCalibration& calibration, std::string label) {
  ReferenceCalibration r;
  r.label = std::move(label);
  for (const auto& c : calibration.cameras) {
    if (!c.intrinsics) continue;
    r.cameras.push_back({c.name, c.model, c.pad_corners_px.value_or(pad_corners_px(c.model, calibration.pad))});
  }
  return r;
}

std::string write_board(const std::filesystem::path& out) {
  const calib::BoardSpec spec;
  const std::string ext = out.extension().string();
  if (ext == ".pdf") {
    std::ofstream f(out, std::ios::binary | std::ios::trunc);
    f << calib::board_pdf(spec);
    if (!f.flush()) throw UserError(fmt::format("cannot write {}", out.string()));
  } else if (ext == ".png") {
    if (Status s = write_image(out, calib::board_image(spec, 12.0)); !s.ok()) throw UserError(s.error().message);
  } else {
    throw UserError(fmt::format("{}: the board is written as .pdf or .png", out.string()));
  }
  return fmt::format(
      "wrote {}: ChArUco board {} x {} squares of {} mm, markers {} mm ({}). Print at 100 % (\"actual "
      "size\"), check one square measures {} mm, and mount it flat and rigid.\n",
      out.string(), spec.squares_x, spec.squares_y, spec.square_mm, spec.marker_mm, "DICT_5X5_100", spec.square_mm);
}

// Every camera's intrinsics from its board views, the cameras shared among the machine's cores
// (each reads through its own SessionReader: a reader decodes with state of its own). A lab's PC
// has a core per camera, and the board search and the fit are a camera's alone: four cameras take
// the time of one. Results come back in camera order; the first error is rethrown here.
std::vector<Result<calib::Intrinsics>> intrinsics_of_cameras(const CalibrationRun& run,
                                                             const SessionCalibrationOptions& o) {
  const std::vector<CameraInfo>& cameras = run.session->cameras();
  const calib::BoardSpec spec;
  std::vector<std::optional<Result<calib::Intrinsics>>> results(cameras.size());
  std::size_t frames_done = 0;
  const std::size_t frames_total = cameras.size() * run.samples.size();
  std::mutex mutex;                                                     // guards frames_done and the progress line
  std::vector<std::unique_ptr<SessionReader>> readers(cameras.size());  // one per thread, opened on use
  run_side_by_side(cameras.size(), cameras.size(), [&](std::size_t c, std::size_t worker) {
    if (!readers[worker]) readers[worker] = open_session(o.session);
    std::vector<calib::BoardView> views;
    for (std::size_t i : run.samples) {
      auto image = readers[worker]->image(i, c);
      if (!image) throw UserError(image.error().message);
      if (!image.value().empty()) views.push_back(calib::detect_board(image.value(), spec));
      const std::lock_guard lock(mutex);  // one line, its count rising
      progress(run.out, "finding the board (all cameras)", ++frames_done, frames_total);
    }
    const cv::Size size(cameras[c].width, cameras[c].height);
    if (!o.save_views.empty()) {  // before the fit: a fit that fails is what they are kept for
      const auto file = o.save_views / (cameras[c].name + ".board-views.yaml");
      if (Status s = calib::save_board_views(file, {size, views}); !s.ok()) throw UserError(s.error().message);
    }
    results[c] = calib::calibrate_intrinsics(views, size, spec);
  });
  std::vector<Result<calib::Intrinsics>> out;
  for (auto& r : results) out.push_back(std::move(*r));
  return out;
}

bool intrinsics_from_session(const SessionCalibrationOptions& o) {
  CalibrationRun run(o, 150);
  if (!o.save_views.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(o.save_views, ec);
    if (ec)
      throw UserError(
          fmt::format("{}: cannot make the folder for the board views: {}", o.save_views.string(), ec.message()));
  }
  std::vector<Result<calib::Intrinsics>> intrinsics = intrinsics_of_cameras(run, o);
  for (std::size_t c = 0; c < run.session->cameras().size(); ++c) {
    const CameraInfo& camera = run.session->cameras()[c];
    auto& got = intrinsics[c];
    if (!got) {  // the other cameras' results are still kept
      run.failed.push_back(fmt::format("{}: {}", camera.name, got.error().message));
      continue;
    }
    const calib::Intrinsics& in = got.value();
    calib::CameraCalibration* entry = run.cal.camera(camera.name);
    if (!entry) entry = &run.cal.cameras.emplace_back();
    entry->name = camera.name;
    entry->serial = camera.serial;
    entry->model = in.model;
    entry->pad.reset();  // a pose belongs to the intrinsics it was solved with
    entry->cells_to_ideal.reset();
    entry->pad_corners_px.reset();
    calib::MeasuredBy m{"charuco_intrinsics",
                        std::filesystem::absolute(o.session).string(),
                        wall_now_ns(),
                        in.rms_px,
                        std::nullopt,
                        {{"views", in.views},
                         {"rejected_views", in.rejected_views},
                         {"repeated_views", in.repeated_views},
                         {"deviation_fx_fy_cx_cy_px", in.deviation},
                         {"corners", in.corners},
                         {"misread_corners", in.misread_corners},
                         {"not_covered", in.missing},
                         {"coverage", in.coverage},
                         {"coverage_grid", {calib::Intrinsics::coverage_cols, calib::Intrinsics::coverage_rows}},
                         {"empty_regions", in.empty_regions}}};
    entry->intrinsics = m;
    say(run.out,
        fmt::format(
            "{}: {} views ({} left out, {} repeats of a still board skipped), {} corners ({} misread left out), RMS "
            "{:.3f} px; fx {:.1f} fy {:.1f} cx {:.1f} cy {:.1f} (the fit's standard deviation: focal {:.1f}, cx "
            "{:.1f}, "
            "cy {:.1f} px)\n",
            camera.name, in.views, in.rejected_views, in.repeated_views, in.corners, in.misread_corners, in.rms_px,
            in.model.K(0, 0), in.model.K(1, 1), in.model.K(0, 2), in.model.K(1, 2),
            // with fx = fy fixed, OpenCV reports the focal length's deviation under one of the two
            std::max(in.deviation[0], in.deviation[1]), in.deviation[2], in.deviation[3]));
    std::string grid;
    for (int r = 0; r < calib::Intrinsics::coverage_rows; ++r) {
      grid += "    ";
      for (int k = 0; k < calib::Intrinsics::coverage_cols; ++k)
        grid += fmt::format("{:>6}", in.coverage[std::size_t(r * calib::Intrinsics::coverage_cols + k)]);
      grid += '\n';
    }
    say(run.out, "  corners per image region:\n" + grid);
    if (!in.empty_regions.empty())
      say(run.out, fmt::format("  no corners yet in: {}. Record more board views there: the lens is not known "
                               "where the board has not been\n",
                               fmt::join(in.empty_regions, ", ")));
    if (!in.missing.empty())
      say(run.out, fmt::format("  not covered (the board session's rule): {}; the lens was fitted, but is less "
                               "certain without them\n",
                               fmt::join(in.missing, "; ")));
    if (run.reference) {
      const calib::CameraModel& tm = reference_camera(*run.reference, camera.name).model;
      const double efx = in.model.K(0, 0) / tm.K(0, 0) - 1, efy = in.model.K(1, 1) / tm.K(1, 1) - 1;
      const double ecx = in.model.K(0, 2) - tm.K(0, 2), ecy = in.model.K(1, 2) - tm.K(1, 2);
      const bool ok = std::abs(efx) <= kFocalTolerance && std::abs(efy) <= kFocalTolerance &&
                      std::abs(ecx) <= kPrincipalTolerancePx && std::abs(ecy) <= kPrincipalTolerancePx;
      run.within_targets = run.within_targets && ok;
      say(run.out, fmt::format("  against {}: focal {:+.3f} % / {:+.3f} %, principal point {:+.2f} / {:+.2f} px ({})\n",
                               run.reference->label, 100 * efx, 100 * efy, ecx, ecy,
                               ok ? "within targets"
                                  : fmt::format("OUTSIDE the targets {} % and {} px", 100 * kFocalTolerance,
                                                kPrincipalTolerancePx)));
    }
    add_to_session(o.session, camera, *entry, m, run.file);
  }
  return run.save_and_report(fmt::format("; next: pvcap calibrate pad SESSION --calibration {}", run.file.string()));
}

bool pad_from_session(const SessionCalibrationOptions& o) {
  if (const auto file = calibration_file(o); !std::filesystem::exists(file))
    throw UserError(
        fmt::format("{}: no calibration file with the cameras' intrinsics; make one first with `pvcap "
                    "calibrate intrinsics BOARD_SESSION --out {}` (or give --calibration)",
                    file.string(), file.string()));
  CalibrationRun run(o, 15);
  for (std::size_t c = 0; c < run.session->cameras().size(); ++c) {
    const CameraInfo& camera = run.session->cameras()[c];
    calib::CameraCalibration* entry = run.cal.camera(camera.name);
    if (!entry || !entry->intrinsics) {
      run.failed.push_back(
          fmt::format("{}: {} has no intrinsics for this camera; run `pvcap calibrate intrinsics` "
                      "on a board session first",
                      camera.name, run.file.string()));
      continue;
    }
    if (entry->model.image_size != cv::Size(camera.width, camera.height)) {
      run.failed.push_back(fmt::format(
          "{}: its intrinsics are for {}x{} images but this session recorded {}x{}; "
          "calibrate the intrinsics at this size",
          camera.name, entry->model.image_size.width, entry->model.image_size.height, camera.width, camera.height));
      continue;
    }
    calib::MarkerAccumulator markers(run.cal.pad);
    for_each_image(*run.session, c, run.samples, "finding the mat's markers", run.out,
                   [&](const cv::Mat& image) { markers.add(image); });
    auto got = calib::calibrate_pad(markers.median(), entry->model, run.cal.pad);
    if (!got) {
      run.failed.push_back(fmt::format("{}: {}", camera.name, got.error().message));
      continue;
    }
    const calib::PadCalibration& p = got.value();
    entry->model = p.model;
    entry->cells_to_ideal = p.cells_to_ideal;
    entry->pad_corners_px = p.pad_corners_px;
    calib::MeasuredBy m{"pad_markers", std::filesystem::absolute(o.session).string(),
                        wall_now_ns(), p.rms_px,
                        p.rms_mm,      {{"markers", p.marker_ids}, {"frames", markers.frames()}}};
    entry->pad = m;
    const cv::Point3d centre = p.model.centre_mm();
    say(run.out,
        fmt::format(
            "{}: {} markers over {} frames, RMS {:.3f} px / {:.3f} mm on the pad; camera at ({:.0f}, {:.0f}) mm, "
            "{:.0f} mm above the pad; grid corners {} {} {} {}\n",
            camera.name, p.marker_ids.size(), markers.frames(), p.rms_px, p.rms_mm, centre.x, centre.y, -centre.z,
            fmt_point(p.pad_corners_px[0]), fmt_point(p.pad_corners_px[1]), fmt_point(p.pad_corners_px[2]),
            fmt_point(p.pad_corners_px[3])));
    if (run.reference) {
      const ReferenceCamera& t = reference_camera(*run.reference, camera.name);
      std::vector<double> errors;
      for (std::size_t k = 0; k < 4; ++k) errors.push_back(cv::norm(p.pad_corners_px[k] - t.pad_corners_px[k]));
      std::sort(errors.begin(), errors.end());
      const double median = (errors[1] + errors[2]) / 2, max = errors[3];
      const bool ok = median <= kCornerMedianPx && max <= kCornerMaxPx;
      run.within_targets = run.within_targets && ok;
      say(run.out,
          fmt::format(
              "  against {}: pad corners median {:.3f} px, max {:.3f} px ({})\n", run.reference->label, median, max,
              ok ? "within targets" : fmt::format("OUTSIDE the targets {} / {} px", kCornerMedianPx, kCornerMaxPx)));
    }
    add_to_session(o.session, camera, *entry, m, run.file);
  }
  return run.save_and_report("");
}

namespace {

// The presses: runs of samples whose total pressure is above 30 % of the session's highest; at most
// `most` of them, spread over the session. One entry per press: its samples, the one of highest
// pressure first (the press's peak), then the others of the press by falling pressure. A camera
// whose frame the peak's sample lacks (a group left incomplete on a loaded capture PC), or in which
// the fingertip is hidden, is checked at the next.
struct Presses {
  std::vector<std::vector<std::size_t>> samples;
  double highest = 0;  // the session's highest total pressure (counts)
};

Presses find_presses(SessionReader& session, std::size_t most, const CalibrationSinks& out) {
  std::vector<std::pair<std::size_t, double>> totals;
  Presses found;
  for (std::size_t i = 0; i < session.sample_count(); ++i) {
    auto info = session.sample_info(i);
    if (!info) throw UserError(info.error().message);
    if (!info.value().pressure) continue;
    auto frame = session.pressure_frame(info.value().pressure->sequence, info.value().pressure->connection);
    if (!frame) continue;
    double total = 0;
    for (auto c : frame.value().counts) total += c;
    totals.emplace_back(i, total);
    found.highest = std::max(found.highest, total);
    if (i % 64 == 0) progress(out, "finding presses", i, session.sample_count());
  }
  progress(out, "finding presses", session.sample_count(), session.sample_count());
  std::vector<std::pair<std::size_t, double>> press;  // the samples of the press under way
  const auto close_press = [&] {
    if (press.empty()) return;
    std::stable_sort(press.begin(), press.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
    std::vector<std::size_t> by_pressure;
    for (const auto& [i, total] : press) by_pressure.push_back(i);
    found.samples.push_back(std::move(by_pressure));
    press.clear();
  };
  for (const auto& [i, total] : totals) {
    if (total > 0.3 * found.highest)
      press.emplace_back(i, total);
    else
      close_press();
  }
  close_press();
  if (found.samples.size() > most) {
    std::vector<std::vector<std::size_t>> some;
    for (std::size_t k : spread(found.samples.size(), most)) some.push_back(found.samples[k]);
    found.samples = std::move(some);
  }
  return found;
}

// Fingertips the operator marked on the operator page (a real rig's way), by camera name.
struct Mark {
  double x, y;
  std::int64_t frame_ns;
};

std::map<std::string, std::vector<Mark>> fingertip_marks(SessionReader& session, const CalibrationSinks& out) {
  std::map<std::string, std::vector<Mark>> marks;
  auto events = session.protocol_events();
  if (!events) throw UserError(events.error().message);
  for (const auto& e : events.value()) {
    if (e.kind != "fingertip_marked") continue;
    try {
      const auto d = nlohmann::json::parse(e.detail);
      marks[d.at("name").get<std::string>()].push_back(
          {d.at("x").get<double>(), d.at("y").get<double>(), d.at("frame_ns").get<std::int64_t>()});
    } catch (const nlohmann::json::exception&) {
      warn(out, fmt::format("a fingertip mark at {} ns is unreadable; left out", e.host_ns));
    }
  }
  return marks;
}

// One camera's disagreements between each press's pressure centroid and the fingertip, px and mm.
struct Disagreements {
  std::vector<double> px, mm;
  void add(const calib::PressDisagreement& d) {
    px.push_back(d.px);
    mm.push_back(d.mm);
  }
};

double median_of(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : (v[v.size() / 2 - 1] + v[v.size() / 2]) / 2;
}

double rms_of(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x * x;
  return std::sqrt(s / double(v.size()));
}

std::string describe_disagreements(const std::string& camera, const char* what, const Disagreements& d) {
  if (d.px.empty()) return "";
  return fmt::format(
      "{}: {} {}presses; pressure vs {}fingertip: median {:.2f} px / {:.2f} mm, max {:.2f} px / {:.2f} mm\n", camera,
      d.px.size(), what, what, median_of(d.px), median_of(d.mm), *std::max_element(d.px.begin(), d.px.end()),
      *std::max_element(d.mm.begin(), d.mm.end()));
}

// The fingertip found in the image at each press, against that press's pressure centroid.
Disagreements check_found_fingertips(SessionReader& session, std::size_t c, const calib::CameraCalibration& entry,
                                     const calib::PadLayout& pad, const Presses& presses, nlohmann::json& each) {
  Disagreements out;
  for (const std::vector<std::size_t>& press : presses.samples) {
    for (std::size_t i : press) {  // the peak first; the next sample of the press where it has no view
      auto s = session.sample(i, PressureMode::Nearest);
      if (!s) throw UserError(s.error().message);
      const auto& pf = s.value().pressure;
      if (!pf || s.value().images.size() <= c || s.value().images[c].empty()) continue;
      const auto centroid = calib::pressure_centroid(s.value().pressure_image, pf->grid_xscale, pf->grid_yscale);
      const auto tip = calib::find_fingertip(s.value().images[c], *entry.pad_corners_px);
      if (!centroid || !tip) continue;
      const auto d = calib::press_disagreement(entry.model, pad, *centroid, *tip);
      out.add(d);
      each.push_back({{"sample", i},
                      {"centroid_cells", {centroid->x, centroid->y}},
                      {"fingertip_px", {tip->x, tip->y}},
                      {"px", d.px},
                      {"mm", d.mm}});
      break;  // one per press
    }
  }
  return out;
}

// The operator's marks: each against the pressure of the sample nearest the marked frame.
Disagreements check_marked_fingertips(SessionReader& session, const std::string& camera, const std::vector<Mark>& marks,
                                      const calib::CameraCalibration& entry, const calib::PadLayout& pad,
                                      double highest, nlohmann::json& each, const CalibrationSinks& sinks) {
  Disagreements out;
  for (const Mark& mark : marks) {
    auto i = session.sample_at(mark.frame_ns);
    if (!i) continue;
    auto s = session.sample(i.value(), PressureMode::Nearest);
    if (!s || !s.value().pressure) continue;
    double total = 0;
    for (auto v : s.value().pressure->counts) total += v;
    if (total <= 0.3 * highest) {
      say(sinks, fmt::format("{}: the fingertip marked at ({:.1f}, {:.1f}) was not during a press; left out\n", camera,
                             mark.x, mark.y));
      continue;
    }
    const auto centroid = calib::pressure_centroid(s.value().pressure_image, s.value().pressure->grid_xscale,
                                                   s.value().pressure->grid_yscale);
    if (!centroid) continue;
    const auto d = calib::press_disagreement(entry.model, pad, *centroid, {mark.x, mark.y});
    out.add(d);
    each.push_back({{"sample", i.value()},
                    {"centroid_cells", {centroid->x, centroid->y}},
                    {"fingertip_px", {mark.x, mark.y}},
                    {"marked", true},
                    {"px", d.px},
                    {"mm", d.mm}});
  }
  return out;
}

}  // namespace

bool check_against_presses(const SessionCalibrationOptions& o) {
  auto session = open_session(o.session);
  const std::filesystem::path file = calibration_file(o);
  if (!std::filesystem::exists(file))
    throw UserError(
        fmt::format("{}: no calibration file; calibrate the pad first (`pvcap calibrate pad`)", file.string()));
  calib::RigCalibration cal = load_or_new(file, *session);
  if (!session->pressure_device())
    throw UserError(fmt::format("{}: the session has no pressure frames to check against", o.session.string()));
  const Presses presses = find_presses(*session, std::size_t(o.frames > 0 ? o.frames : 40), o.sinks);
  if (presses.samples.empty())
    throw UserError(
        fmt::format("{}: no presses found; record a few presses on the pad (the protocol's calibration "
                    "routine, or any pressing) and check again",
                    o.session.string()));
  auto marks = fingertip_marks(*session, o.sinks);

  bool ok = true;
  for (std::size_t c = 0; c < session->cameras().size(); ++c) {
    const CameraInfo& camera = session->cameras()[c];
    calib::CameraCalibration* entry = cal.camera(camera.name);
    if (!entry || !entry->pad) {
      warn(o.sinks,
           fmt::format("{}: no pad calibration in {}; run `pvcap calibrate pad` first", camera.name, file.string()));
      ok = false;
      continue;
    }
    nlohmann::json each = nlohmann::json::array();
    const Disagreements found = check_found_fingertips(*session, c, *entry, cal.pad, presses, each);
    const Disagreements marked = check_marked_fingertips(*session, camera.name, marks[camera.name], *entry, cal.pad,
                                                         presses.highest, each, o.sinks);
    if (found.px.empty() && marked.px.empty()) {
      warn(o.sinks, fmt::format("{}: the fingertip was not seen in any of the {} presses and none was marked (click "
                                "it on the operator page's camera view during a press)",
                                camera.name, presses.samples.size()));
      ok = false;
      continue;
    }
    say(o.sinks,
        describe_disagreements(camera.name, "", found) + describe_disagreements(camera.name, "marked ", marked));
    Disagreements all = found;
    all.px.insert(all.px.end(), marked.px.begin(), marked.px.end());
    all.mm.insert(all.mm.end(), marked.mm.begin(), marked.mm.end());
    calib::MeasuredBy m{"press_check",  std::filesystem::absolute(o.session).string(),
                        wall_now_ns(),  rms_of(all.px),
                        rms_of(all.mm), {{"presses", each}}};
    add_to_session(o.session, camera, *entry, m, file);
  }
  return ok;
}

}  // namespace pvcap::calib
