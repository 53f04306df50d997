#include "replay/replay_composer.h"

#include <algorithm>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "calib/pad_layout.h"
#include "codec/sensel_units.h"
#include "protocol/takes.h"
#include "calib/recorded_calibration.h"

namespace pvcap::replay {

namespace {
const cv::Scalar kBackground(24, 24, 24), kText(235, 235, 235), kDim(150, 150, 150);

// The pressure of a frame on the 185 x 105 sensor grid, in kPa.
cv::Mat pressure_kpa(const PressureFrame& p) {
  const sensel::Grid grid{p.grid_cols, p.grid_rows, p.grid_xscale, p.grid_yscale};
  if (grid.cells() <= 0 || p.counts.size() != std::size_t(grid.cells()) || grid.xscale <= 0 || grid.yscale <= 0)
    return {};
  const std::vector<float> up = sensel::upsample(p.counts, grid);
  cv::Mat counts(grid.out_rows(), grid.out_cols(), CV_32F, const_cast<float*>(up.data()));
  cv::Mat kpa;
  counts.convertTo(kpa, CV_32F, sensel::upsampled_sensel_kpa(1.0, grid));
  return kpa;
}

cv::Scalar force_colour(const std::string& force) {
  if (force == "high") return {60, 60, 230};
  if (force == "low") return {60, 200, 240};
  return {200, 200, 200};
}

void text(cv::Mat& img, const std::string& s, cv::Point at, double scale, const cv::Scalar& colour, int weight = 1) {
  cv::putText(img, s, at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, weight, cv::LINE_AA);
}
}  // namespace

Result<ReplayComposer> ReplayComposer::open(SessionReader& reader, const std::filesystem::path& dir,
                                            double pressure_full_scale_kpa) {
  ReplayComposer c(reader);
  c.full_scale_kpa_ = pressure_full_scale_kpa;
  // A view is a third of a 1080p image across: the half-size image (each Bayer cell one pixel, no
  // interpolation) has more than it shows, at a fraction of a full demosaic's cost.
  reader.set_demosaic(Demosaic::HalfSize);
  c.dir_ = dir;
  auto cal = calib::pad_calibrations(reader);
  if (!cal) return cal.error();
  const calib::PadLayout pad = calib::default_pad_layout();
  for (std::size_t k = 0; k < reader.cameras().size(); ++k) {
    const auto& cc = k < cal.value().size() ? cal.value()[k] : std::nullopt;
    const CameraInfo& info = reader.cameras()[k];
    if (cc && cc->model.image_size == cv::Size(info.width, info.height))
      c.projectors_.emplace_back(
          calib::PressureProjector(cc->model, pad).scaled(Layout::fitted(cc->model.image_size).size()));
    else
      c.projectors_.emplace_back(std::nullopt);
  }
  // Takes are optional: a session without a protocol replays without labels.
  if (auto takes = protocol::read_takes(dir)) {
    const std::string folder = dir.filename().string();
    for (const auto& t : takes.value().takes) {
      if (!t.first_sample || !t.end_sample || std::filesystem::path(t.session).filename().string() != folder) continue;
      c.takes_.push_back(
          {{t.sequence, t.action, t.hand, t.force, t.status, t.repetitions}, *t.first_sample, *t.end_sample});
    }
  }
  return c;
}

std::optional<TakeLabel> ReplayComposer::take_at(std::size_t i) const {
  for (auto it = takes_.rbegin(); it != takes_.rend(); ++it)  // a retake's samples: the latest take
    if (i >= it->first && i < it->end) return it->label;
  return std::nullopt;
}

Result<std::pair<std::size_t, std::size_t>> ReplayComposer::take_samples(const std::string& name) const {
  std::string names;
  for (const auto& t : takes_) {
    if (t.label.name == name) return std::make_pair(t.first, t.end);
    names += (names.empty() ? "" : ", ") + t.label.name;
  }
  return Error{takes_.empty() ? fmt::format("no take '{}': the session has no protocol takes", name)
                              : fmt::format("no take '{}'; the session's takes: {}", name, names)};
}

Result<cv::Mat> ReplayComposer::compose(std::size_t i) {
  for (std::size_t k = camera_readers_.size(); k < reader_->cameras().size() && k < 4; ++k) {  // on first use
    auto r = SessionReader::open(dir_);
    if (!r) return r.error();
    r.value()->set_demosaic(Demosaic::HalfSize);
    r.value()->set_view_videos(view_videos_);
    const CameraInfo& info = reader_->cameras()[k];
    if (info.width > 0 && info.height > 0)  // made at its view's size
      r.value()->set_image_size(Layout::fitted({info.width, info.height}).size());
    camera_readers_.push_back(std::move(r.value()));
  }
  // Every camera's frame decoded on its own reader, in parallel.
  std::vector<cv::Mat> images(camera_readers_.size());
  std::vector<std::string> errors(camera_readers_.size());
  cv::parallel_for_(cv::Range(0, int(camera_readers_.size())), [&](const cv::Range& range) {
    for (int c = range.start; c < range.end; ++c) {
      auto image = camera_readers_[std::size_t(c)]->image(i, std::size_t(c));
      if (image)
        images[std::size_t(c)] = std::move(image.value());
      else
        errors[std::size_t(c)] = image.error().message;
    }
  });
  for (const auto& e : errors)
    if (!e.empty()) return Error{e};
  return compose(i, std::move(images));
}

Result<cv::Mat> ReplayComposer::compose(std::size_t i, std::vector<cv::Mat> images) {
  auto info = reader_->sample_info(i);
  if (!info) return info.error();
  Sample s;
  s.info = std::move(info.value());
  if (s.info.pressure) {
    auto p = reader_->pressure_frame(s.info.pressure->sequence, s.info.pressure->connection);
    if (!p) return p.error();
    s.pressure = std::move(p.value());
  }
  s.images = std::move(images);
  cv::Mat canvas(Layout::kHeight, Layout::kWidth, CV_8UC3, kBackground);
  const cv::Mat kpa = s.pressure ? pressure_kpa(*s.pressure) : cv::Mat();
  double peak_kpa = 0;
  if (!kpa.empty()) cv::minMaxLoc(kpa, nullptr, &peak_kpa);
  for (std::size_t c = 0; c < reader_->cameras().size() && c < 4; ++c) {
    cv::Mat tile = canvas(Layout::view(c));
    const std::string& name = reader_->cameras()[c].name;
    if (c >= s.images.size() || s.images[c].empty()) {
      std::string why = "no frame";
      for (const auto& sc : s.info.cameras)
        if (sc.device_id == reader_->cameras()[c].device_id && !sc.reason.empty()) why += " (" + sc.reason + ")";
      text(tile, name + ": " + why, {20, Layout::kViewHeight / 2}, 0.7, kDim);
      continue;
    }
    const CameraInfo& info = reader_->cameras()[c];
    const cv::Rect fit = Layout::fitted({info.width, info.height});
    cv::Mat view = tile(fit);  // resized straight into the canvas (same size and type: no new buffer)
    // The readers make images at this size (then this is a copy); any other size is scaled.
    cv::resize(s.images[c], view, fit.size(), 0, 0, cv::INTER_LINEAR);
    if (peak_kpa > 0 && projectors_[c]) {  // nothing pressed, nothing drawn
      // Drawn only over the pad's footprint: the pressure is zero elsewhere.
      const cv::Rect pad = projectors_[c]->footprint();
      if (!pad.empty() && (pad & cv::Rect({0, 0}, view.size())) == pad)
        calib::overlay_pressure(view(pad), projectors_[c]->project_footprint(kpa), full_scale_kpa_).copyTo(view(pad));
    }
    const std::string label = name + (projectors_[c] ? "" : " (no calibration: no overlay)");
    int base = 0;
    const cv::Size size = cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX, 0.6, 1, &base);
    const cv::Point at(10, Layout::kViewHeight - 12);
    cv::rectangle(tile, {at.x - 4, at.y - size.height - 6}, {at.x + size.width + 4, at.y + base + 2}, kBackground,
                  cv::FILLED);
    text(tile, label, at, 0.6, kText, 1);
  }

  // The panel: the pressure image as the sensor saw it, then what was happening.
  const int x0 = 2 * Layout::kViewWidth + 15;
  const cv::Rect pressure_box(x0, 15, 370, 210);
  if (!kpa.empty()) {
    cv::Mat level;
    kpa.convertTo(level, CV_8U, 255.0 / full_scale_kpa_);
    cv::Mat box = canvas(pressure_box);  // resized straight into its place
    cv::resize(calib::inferno(level), box, pressure_box.size(), 0, 0, cv::INTER_NEAREST);
  } else {
    text(canvas, "no pressure frame", {x0 + 90, 125}, 0.6, kDim);
  }
  cv::rectangle(canvas, pressure_box, kDim, 1);
  int y = 260;
  auto line = [&](const std::string& s, double scale, const cv::Scalar& colour, int weight = 1) {
    text(canvas, s, {x0, y}, scale, colour, weight);
    y += int(38 * scale / 0.7);
  };
  const double t_s = double(s.info.t_ns - reader_->info().started_host_ns) * 1e-9;
  line(fmt::format("t = {:.2f} s   sample {}", t_s, i), 0.7, kText, 2);
  if (kpa.empty())
    line("pressure: none", 0.6, kDim);
  else
    line(fmt::format("peak {:.0f} kPa (scale {:.0f})", peak_kpa, full_scale_kpa_), 0.6, kText);
  y += 10;
  if (const auto take = take_at(i)) {
    line(take->action, 0.7, kText, 2);
    line("hand: " + take->hand, 0.7, kText);
    line("force: " + take->force, 0.7, force_colour(take->force), 2);
    line(fmt::format("repetitions: {}", take->repetitions), 0.7, kText);
    line("take: " + take->status, 0.7, take->status == "done" ? cv::Scalar(120, 220, 120) : kDim);
    line(take->name, 0.5, kDim);
  } else {
    line("between takes", 0.7, kDim);
  }
  return canvas;
}

std::vector<std::size_t> ReplayComposer::take_starts() const {
  std::vector<std::size_t> out;
  for (const auto& t : takes_) out.push_back(t.first);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

}  // namespace pvcap::replay
