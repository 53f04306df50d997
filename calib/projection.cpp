#include "calib/projection.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace pvcap::calib {

cv::Mat warp_pressure(const cv::Mat& pressure, const cv::Matx33d& cells_to_image, cv::Size size) {
  CV_Assert(pressure.type() == CV_32F);
  cv::Mat out;
  cv::warpPerspective(pressure, out, cells_to_image, size, cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
  return out;
}

PressureProjector::PressureProjector(const CameraModel& camera, const PadLayout& pad) {
  const cv::Mat rays = camera.normalised_rays();
  // A ray (x, y, 1) meets the pad plane at (u, v, 1) ~ [r1 r2 t]^-1 (x, y, 1) (mm); cells = mm / pitch.
  const cv::Matx33d rt(camera.R(0, 0), camera.R(0, 1), camera.t[0], camera.R(1, 0), camera.R(1, 1), camera.t[1],
                       camera.R(2, 0), camera.R(2, 1), camera.t[2]);
  const cv::Matx33d to_cells = cv::Matx33d(1 / pad.pitch_mm, 0, 0, 0, 1 / pad.pitch_mm, 0, 0, 0, 1) * rt.inv();
  map_.create(rays.size(), CV_32FC2);
  for (int y = 0; y < rays.rows; ++y) {
    const auto* d = rays.ptr<cv::Vec2f>(y);
    auto* out = map_.ptr<cv::Vec2f>(y);
    for (int x = 0; x < rays.cols; ++x) {
      const cv::Vec3d q = to_cells * cv::Vec3d(d[x][0], d[x][1], 1.0);
      out[x] = q[2] > 1e-12 ? cv::Vec2f(float(q[0] / q[2]), float(q[1] / q[2])) : cv::Vec2f(-1e6f, -1e6f);
    }
  }
  cells_ = cv::Size(pad.cols, pad.rows);
  find_footprint();
}

void PressureProjector::find_footprint() {
  // Bilinear resampling with a zero border gives a pixel pressure only when its point lies within
  // one cell of the grid; two cells of margin also cover the fixed-point map's 1/32-cell rounding.
  int x0 = map_.cols, y0 = map_.rows, x1 = -1, y1 = -1;
  for (int y = 0; y < map_.rows; ++y) {
    const auto* m = map_.ptr<cv::Vec2f>(y);
    for (int x = 0; x < map_.cols; ++x)
      if (m[x][0] > -2 && m[x][0] < cells_.width + 1 && m[x][1] > -2 && m[x][1] < cells_.height + 1) {
        x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
      }
  }
  footprint_ = x1 < 0 ? cv::Rect() : cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1);
}

cv::Mat PressureProjector::project(const cv::Mat& pressure) const {
  CV_Assert(pressure.type() == CV_32F);
  // A pressure image of the pad's grid reaches only the footprint: the rest is zero, unsampled.
  const cv::Rect r = pressure.size() == cells_ ? footprint_ : cv::Rect({0, 0}, map_.size());
  cv::Mat out(map_.size(), CV_32F, cv::Scalar(0));
  if (r.empty()) return out;
  cv::Mat part = out(r);
  resample(pressure, r, part);
  return out;
}

cv::Mat PressureProjector::project_footprint(const cv::Mat& pressure) const {
  CV_Assert(pressure.type() == CV_32F);
  cv::Mat out(footprint_.size(), CV_32F);
  if (!footprint_.empty()) resample(pressure, footprint_, out);
  return out;
}

void PressureProjector::resample(const cv::Mat& pressure, cv::Rect where, cv::Mat& out) const {
  if (!fixed_map_.empty())  // the off-pad marker saturates to -32768: still far outside the pressure image
    cv::remap(pressure, out, fixed_map_(where), fixed_fraction_(where), cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
  else
    cv::remap(pressure, out, map_(where), cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
}

PressureProjector PressureProjector::scaled(cv::Size view) const {
  PressureProjector out;
  // Linear resampling of a smooth map; where it mixes in the off-pad marker the result stays far
  // off the pad, so the view shows no pressure there either.
  cv::resize(map_, out.map_, view, 0, 0, cv::INTER_LINEAR);
  cv::convertMaps(out.map_, cv::noArray(), out.fixed_map_, out.fixed_fraction_, CV_16SC2);
  out.cells_ = cells_;
  out.find_footprint();
  return out;
}

cv::Mat pixel_area_mm2(const cv::Matx33d& cells_to_image, cv::Size size, const PadLayout& pad) {
  // The inverse map g = H^-1 (image -> cells) has Jacobian determinant det(g) / w^3, w its third row.
  const cv::Matx33d g = cells_to_image.inv();
  const double det = cv::determinant(g), cell_area = pad.pitch_mm * pad.pitch_mm;
  cv::Mat out(size, CV_32F);
  for (int y = 0; y < size.height; ++y) {
    auto* row = out.ptr<float>(y);
    for (int x = 0; x < size.width; ++x) {
      const double w = g(2, 0) * x + g(2, 1) * y + g(2, 2);
      const double u = (g(0, 0) * x + g(0, 1) * y + g(0, 2)) / w, v = (g(1, 0) * x + g(1, 1) * y + g(1, 2)) / w;
      const bool on_pad = u >= -0.5 && v >= -0.5 && u < pad.cols - 0.5 && v < pad.rows - 0.5;
      row[x] = on_pad ? float(std::abs(det / (w * w * w)) * cell_area) : 0.0f;
    }
  }
  return out;
}

cv::Mat inferno(const cv::Mat& level) {
  CV_Assert(level.type() == CV_8U);
  static const cv::Mat table = [] {
    cv::Mat ramp(256, 1, CV_8U), colours;
    for (int i = 0; i < 256; ++i) ramp.at<uchar>(i) = uchar(i);
    cv::applyColorMap(ramp, colours, cv::COLORMAP_INFERNO);
    return colours;
  }();
  cv::Mat colour;
  cv::applyColorMap(level, colour, table);
  return colour;
}

cv::Mat overlay_pressure(const cv::Mat& bgr, const cv::Mat& pressure, double full_scale, double opacity) {
  CV_Assert(bgr.type() == CV_8UC3 && pressure.type() == CV_32F && bgr.size() == pressure.size());
  cv::Mat out = bgr.clone();
  if (full_scale <= 0) return out;
  // Only where there is pressure (a few fingertips: a small part of the image) is anything drawn.
  const cv::Rect roi = cv::boundingRect(pressure > 0);
  if (roi.empty()) return out;
  cv::Mat level;
  pressure(roi).convertTo(level, CV_8U, 255.0 / full_scale);
  const cv::Mat colour = inferno(level);
  for (int y = 0; y < roi.height; ++y) {
    const float* p = pressure.ptr<float>(roi.y + y) + roi.x;
    const auto* c = colour.ptr<cv::Vec3b>(y);
    auto* o = out.ptr<cv::Vec3b>(roi.y + y) + roi.x;
    for (int x = 0; x < roi.width; ++x) {
      if (!(p[x] > 0)) continue;
      const double a = opacity * std::min(1.0, p[x] / (0.1 * full_scale));
      for (int k = 0; k < 3; ++k) o[x][k] = cv::saturate_cast<uchar>((1 - a) * o[x][k] + a * c[x][k]);
    }
  }
  return out;
}

double sensor_force_n(const cv::Mat& pressure_kpa, const PadLayout& pad) {
  return cv::sum(pressure_kpa)[0] * pad.pitch_mm * pad.pitch_mm * 1e-3;  // kPa * mm^2 = 1e-3 N
}

cv::Mat warp_pressure_conserving(const cv::Mat& pressure_kpa, const cv::Matx33d& cells_to_image, cv::Size size,
                                 const PadLayout& pad) {
  return ConservingWarp(cells_to_image, size, pad)(pressure_kpa);
}

namespace {

// Where each pixel of `size` samples the pressure image under `cells_to_image`, as cv::convertMaps
// makes it (CV_16SC2 whole cells + CV_16UC1 1/32 fractions): the map cv::remap then follows.
void sampling_map(const cv::Matx33d& cells_to_image, cv::Size size, cv::Mat& cells, cv::Mat& fraction) {
  const cv::Matx33d g = cells_to_image.inv();
  cv::Mat map(size, CV_32FC2);
  for (int y = 0; y < size.height; ++y) {
    auto* row = map.ptr<cv::Vec2f>(y);
    for (int x = 0; x < size.width; ++x) {
      const double w = g(2, 0) * x + g(2, 1) * y + g(2, 2);
      const double ok = w != 0 ? 1 / w : 0;  // a pixel on the horizon samples nothing (off the map)
      row[x] = w != 0 ? cv::Vec2f(float((g(0, 0) * x + g(0, 1) * y + g(0, 2)) * ok),
                                  float((g(1, 0) * x + g(1, 1) * y + g(1, 2)) * ok))
                      : cv::Vec2f(-1e6f, -1e6f);
    }
  }
  cv::convertMaps(map, cv::noArray(), cells, fraction, CV_16SC2);
}

// Above this many pixels in the pad's whole footprint (a crop blown up many times), a pixel is far
// smaller than a cell and every cell's reach is its own area (the integral's limit) to within 1e-3.
constexpr double kMaxReachPixels = 16e6;

}  // namespace

cv::Mat cell_reach_mm2(const cv::Matx33d& cells_to_image, const PadLayout& pad) {
  const double cell_area = pad.pitch_mm * pad.pitch_mm;
  cv::Mat reach(pad.rows, pad.cols, CV_64F, cv::Scalar(0));
  // Bilinear sampling with a zero border reaches a cell's value from points within one cell of it:
  // the footprint is the grid grown by a cell, wherever it lies (inside this image or not).
  const std::vector<cv::Point2d> grid{
      {-1, -1}, {double(pad.cols), -1}, {double(pad.cols), double(pad.rows)}, {-1, double(pad.rows)}};
  std::vector<cv::Point2d> corners;
  cv::perspectiveTransform(grid, corners, cells_to_image);
  cv::Point2d lo = corners[0], hi = corners[0];
  for (const cv::Point2d& p : corners) {
    lo.x = std::min(lo.x, p.x), lo.y = std::min(lo.y, p.y);
    hi.x = std::max(hi.x, p.x), hi.y = std::max(hi.y, p.y);
  }
  if (!(hi.x - lo.x < 1e5 && hi.y - lo.y < 1e5)) return reach.setTo(cell_area);  // a pad seen edge-on
  const cv::Rect frame(int(std::floor(lo.x)) - 1, int(std::floor(lo.y)) - 1, int(std::ceil(hi.x - lo.x)) + 3,
                       int(std::ceil(hi.y - lo.y)) + 3);
  if (double(frame.width) * frame.height > kMaxReachPixels) return reach.setTo(cell_area);
  // The same homography, with the footprint's corner as pixel (0, 0).
  const cv::Matx33d shifted = cv::Matx33d(1, 0, -frame.x, 0, 1, -frame.y, 0, 0, 1) * cells_to_image;
  const cv::Mat area = pixel_area_mm2(shifted, frame.size(), pad);
  cv::Mat cells, fraction;
  sampling_map(shifted, frame.size(), cells, fraction);
  // remap's bilinear weights at its fixed-point precision: (1 - fx, fx) x (1 - fy, fy) in 1/32 steps.
  for (int y = 0; y < frame.height; ++y) {
    const auto* a = area.ptr<float>(y);
    const auto* c = cells.ptr<cv::Vec2s>(y);
    const auto* f = fraction.ptr<ushort>(y);
    for (int x = 0; x < frame.width; ++x) {
      if (!(a[x] > 0)) continue;
      const double fx = (f[x] & 31) / 32.0, fy = (f[x] >> 5) / 32.0;
      const double w[2][2] = {{(1 - fx) * (1 - fy), fx * (1 - fy)}, {(1 - fx) * fy, fx * fy}};
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          const int u = c[x][0] + dx, v = c[x][1] + dy;
          if (u >= 0 && v >= 0 && u < pad.cols && v < pad.rows) reach.at<double>(v, u) += w[dy][dx] * a[x];
        }
    }
  }
  return reach;
}

ConservingWarp::ConservingWarp(const cv::Matx33d& cells_to_image, cv::Size size, const PadLayout& pad)
    : pad_(pad), area_mm2_(pixel_area_mm2(cells_to_image, size, pad)) {
  cell_reach_mm2(cells_to_image, pad).convertTo(reach_mm2_, CV_32F);
  sampling_map(cells_to_image, size, map_, fraction_);
}

cv::Mat ConservingWarp::operator()(const cv::Mat& pressure_kpa, double* force_n) const {
  CV_Assert(pressure_kpa.type() == CV_32F && pressure_kpa.size() == reach_mm2_.size());
  cv::Mat warped;
  cv::remap(pressure_kpa, warped, map_, fraction_, cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
  // The force the warp puts in the pad's whole footprint, this image's part of it or not: one scale
  // for every image of the same homography, so a crop holds exactly the full image's pressure there.
  const double reached = pressure_kpa.dot(reach_mm2_) * 1e-3;
  const double on_sensor = sensor_force_n(pressure_kpa, pad_);
  if (reached > 0) warped *= on_sensor / reached;
  if (force_n) *force_n = on_sensor;
  return warped;
}

double ConservingWarp::force_in_image_n(const cv::Mat& warped) const {
  CV_Assert(warped.type() == CV_32F && warped.size() == area_mm2_.size());
  return warped.dot(area_mm2_) * 1e-3;
}

cv::Rect paper_crop_box(const std::array<cv::Point2d, 4>& corners, cv::Size image, double margin, cv::Size network) {
  cv::Point2d lo = corners[0], hi = corners[0];
  for (const cv::Point2d& p : corners) {
    lo.x = std::min(lo.x, p.x), lo.y = std::min(lo.y, p.y);
    hi.x = std::max(hi.x, p.x), hi.y = std::max(hi.y, p.y);
  }
  lo -= cv::Point2d(margin, margin);
  hi += cv::Point2d(margin, margin);
  // numpy's round: halves to even, as nearbyint in the default rounding mode.
  const cv::Point2d centre(std::nearbyint((lo.x + hi.x) / 2), std::nearbyint((lo.y + hi.y) / 2));
  double span_x = (hi.x - lo.x) / 2, span_y = (hi.y - lo.y) / 2;
  const double aspect = double(network.height) / network.width;
  if (span_x * aspect > span_y)
    span_y = span_x * aspect;
  else
    span_x = span_y / aspect;
  // Python's int() truncates toward zero.
  const int x0 = std::max(int(std::trunc(centre.x - span_x)), 0);
  const int x1 = std::min(int(std::trunc(centre.x + span_x)), image.width);
  const int y0 = std::max(int(std::trunc(centre.y - span_y)), 0);
  const int y1 = std::min(int(std::trunc(centre.y + span_y)), image.height);
  return {x0, y0, std::max(0, x1 - x0), std::max(0, y1 - y0)};
}

cv::Mat apply_crop(const cv::Mat& image, const cv::Rect& box, cv::Size network) {
  cv::Mat out;
  cv::resize(image(box), out, network, 0, 0, cv::INTER_LINEAR);
  return out;
}

}  // namespace pvcap::calib
