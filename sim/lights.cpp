#include "sim/lights.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "calib/pad_layout.h"
#include "capture/genicam_features.h"

namespace pvcap::sim {

namespace {
cv::Point2d pad_centre_mm() {
  const auto c = calib::default_pad_layout().grid_corners_mm();
  return {(c[0].x + c[2].x) / 2, (c[0].y + c[2].y) / 2};
}
}  // namespace

cv::Point3d default_lamp_position(const std::string& name, std::size_t index) {
  const cv::Point2d c = pad_centre_mm();
  if (name == "L") return calib::pad_point(c.x - 350, c.y + 40, 380);
  if (name == "C") return calib::pad_point(c.x, c.y - 300, 420);
  if (name == "R") return calib::pad_point(c.x + 350, c.y + 40, 380);
  // Other letters: around the pad, a quarter turn apart.
  const double a = 0.7 + 1.57 * double(index);
  return calib::pad_point(c.x + 400 * std::cos(a), c.y + 400 * std::sin(a), 520);
}

SimLights::SimLights(const RigConfig& rig, std::string off, double lag_s, const std::filesystem::path& truth_dir)
    : off_(std::move(off)), lag_ns_(std::int64_t(std::max(0.0, lag_s) * 1e9)) {
  for (std::size_t i = 0; i < rig.lights.size(); ++i) {
    const LightConfig& l = rig.lights[i];
    SimLamp lamp;
    lamp.name = l.name;
    for (std::size_t c = 0; c < rig.cameras.size(); ++c)
      if (rig.cameras[c].name == l.camera) lamp.camera = int(c);
    lamp.line = line_number(l.line);
    lamp.position_mm = default_lamp_position(l.name, i);
    lamps_.push_back(lamp);
  }
  camera_lines_.assign(rig.cameras.size(), 0);
  changes_.push_back({INT64_MIN, 0});
  if (!lamps_.empty()) {
    truth_.open(truth_dir / "lights.csv", std::ios::app);
    truth_ << "host_ns,lit,driven\n" << std::flush;
  }
}

void SimLights::outputs(int camera, std::uint32_t line_mask, std::int64_t host_ns) {
  std::lock_guard lock(mu_);
  if (camera < 0 || std::size_t(camera) >= camera_lines_.size()) return;
  camera_lines_[std::size_t(camera)] = line_mask;
  std::uint32_t driven = 0;
  for (std::size_t i = 0; i < lamps_.size(); ++i) {
    const SimLamp& l = lamps_[i];
    if (l.line >= 0 && (camera_lines_[std::size_t(l.camera)] >> l.line & 1u)) driven |= 1u << i;
  }
  if (driven == driven_) return;
  driven_ = driven;
  std::uint32_t lit = driven;
  for (std::size_t i = 0; i < lamps_.size(); ++i)
    if (off_.find(lamps_[i].name) != std::string::npos) lit &= ~(1u << i);  // a lamp that does not come on
  const std::int64_t at = host_ns + lag_ns_;
  // Changes come in time order; one that takes effect before the last (never, with one lag) replaces it.
  while (changes_.size() > 1 && changes_.back().at_ns >= at) changes_.pop_back();
  changes_.push_back({at, lit});
  if (changes_.size() > 4096) changes_.erase(changes_.begin() + 1, changes_.begin() + 2048);
  std::string lit_names, driven_names;
  for (std::size_t i = 0; i < lamps_.size(); ++i) {
    if (lit >> i & 1u) lit_names += lamps_[i].name;
    if (driven >> i & 1u) driven_names += lamps_[i].name;
  }
  truth_ << at << ',' << (lit_names.empty() ? "-" : lit_names) << ',' << (driven_names.empty() ? "-" : driven_names)
         << '\n'
         << std::flush;
}

std::uint32_t SimLights::lit_at(std::int64_t host_ns) const {
  std::lock_guard lock(mu_);
  for (auto it = changes_.rbegin(); it != changes_.rend(); ++it)
    if (it->at_ns <= host_ns) return it->mask;
  return 0;
}

std::vector<cv::Mat> lamp_shading(const calib::CameraModel& camera, const std::vector<SimLamp>& lamps) {
  const cv::Size size(std::max(1, camera.image_size.width / 4), std::max(1, camera.image_size.height / 4));
  calib::CameraModel small = camera;
  small.image_size = size;
  small.K(0, 0) /= 4, small.K(1, 1) /= 4, small.K(0, 2) /= 4, small.K(1, 2) /= 4;
  const cv::Mat rays = small.normalised_rays();
  const cv::Matx33d Rt = camera.R.t();
  const cv::Vec3d centre = -(Rt * camera.t);
  const cv::Point2d pad = pad_centre_mm();
  // A spot lamp aimed at the pad's centre, on the table: its beam's falloff (cos^6 of the angle off
  // its axis) x height / distance^3 (the cosine law over the inverse square), as a share of what it
  // gives the pad's centre. The beam makes each lamp light one side of every view more than the other.
  const auto irradiance = [pad](const cv::Point3d& lamp, double x, double y) {
    const double h = -lamp.z, dx = x - lamp.x, dy = y - lamp.y;
    const double d = std::sqrt(dx * dx + dy * dy + h * h);
    const double ax = pad.x - lamp.x, ay = pad.y - lamp.y, a = std::sqrt(ax * ax + ay * ay + h * h);
    const double cos_off_axis = std::max(0.0, (dx * ax + dy * ay + h * h) / (d * a));
    return std::pow(cos_off_axis, 6) * h / (d * d * d);
  };
  std::vector<cv::Mat> out;
  const double share = (1.0 - kAmbientLight) / double(std::max<std::size_t>(1, lamps.size()));
  for (const SimLamp& lamp : lamps) {
    cv::Mat s(size, CV_32F);
    const double at_centre = irradiance(lamp.position_mm, pad.x, pad.y);
    for (int y = 0; y < size.height; ++y) {
      const auto* ray = rays.ptr<cv::Vec2f>(y);
      auto* row = s.ptr<float>(y);
      for (int x = 0; x < size.width; ++x) {
        const cv::Vec3d d = Rt * cv::Vec3d(ray[x][0], ray[x][1], 1.0);
        double px = pad.x, py = pad.y;
        if (std::abs(d[2]) > 1e-9) {
          const double k = -centre[2] / d[2];
          if (k > 0) px = centre[0] + k * d[0], py = centre[1] + k * d[1];
        }
        row[x] = float(lamp.intensity * share * irradiance(lamp.position_mm, px, py) / at_centre);
      }
    }
    out.push_back(std::move(s));
  }
  return out;
}

cv::Mat lit_image(const cv::Mat& image, const std::vector<cv::Mat>& shading, std::uint32_t mask) {
  if (shading.empty()) return image;
  cv::Mat gain(shading[0].size(), CV_32F, cv::Scalar(kAmbientLight));
  for (std::size_t i = 0; i < shading.size(); ++i)
    if (mask >> i & 1u) gain += shading[i];
  cv::Mat full;
  cv::resize(gain, full, image.size(), 0, 0, cv::INTER_LINEAR);
  if (image.channels() > 1) cv::cvtColor(full, full, cv::COLOR_GRAY2BGR);
  cv::Mat out;
  image.convertTo(out, CV_32F);
  out = out.mul(full);
  out.convertTo(out, image.type());
  return out;
}

double light_at(const std::vector<cv::Mat>& shading, std::uint32_t mask, cv::Point2d pixel, cv::Size image_size) {
  double g = kAmbientLight;
  for (std::size_t i = 0; i < shading.size(); ++i) {
    if (!(mask >> i & 1u)) continue;
    const cv::Mat& s = shading[i];
    const int x = std::clamp(int(pixel.x * s.cols / std::max(1, image_size.width)), 0, s.cols - 1);
    const int y = std::clamp(int(pixel.y * s.rows / std::max(1, image_size.height)), 0, s.rows - 1);
    g += s.at<float>(y, x);
  }
  return g;
}

}  // namespace pvcap::sim
