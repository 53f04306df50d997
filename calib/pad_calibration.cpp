#include "calib/pad_calibration.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <opencv2/aruco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace pvcap::calib {

namespace {
cv::Mat grey_of(const cv::Mat& image) {
  if (image.channels() == 1) return image;
  cv::Mat grey;
  cv::cvtColor(image, grey, image.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  return grey;
}
}  // namespace

std::map<int, MarkerCorners> detect_pad_markers(const cv::Mat& image, const PadLayout& pad) {
  const cv::Mat grey = grey_of(image);
  // The mat's markers are large in any view of the pad (60-90 px at 1080p): they are found on a
  // half-size image (a quarter of the work, which keeps detection and pose near 10 ms a frame on
  // one core), then their corners are refined on the full one.
  const int scale = grey.cols >= 1200 ? 2 : 1;
  cv::Mat search = grey;
  if (scale > 1) cv::resize(grey, search, grey.size() / scale, 0, 0, cv::INTER_AREA);
  const auto dict = cv::aruco::getPredefinedDictionary(cv::aruco::PREDEFINED_DICTIONARY_NAME(pad.dictionary));
  auto params = cv::aruco::DetectorParameters::create();
  params->cornerRefinementMethod = cv::aruco::CORNER_REFINE_NONE;
  std::vector<std::vector<cv::Point2f>> corners;
  std::vector<int> ids;
  cv::aruco::detectMarkers(search, dict, corners, ids, params);
  std::map<int, MarkerCorners> out;
  std::vector<int> twice;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    if (!pad.marker(ids[i]) || corners[i].size() != 4) continue;  // not one of the mat's markers
    if (out.count(ids[i])) {  // the same id twice: something else looks like it; trust neither
      twice.push_back(ids[i]);
      continue;
    }
    std::vector<cv::Point2f> full;
    // Pixel centres: x_full = scale * x_half + (scale - 1) / 2.
    const cv::Point2f shift(0.5f * float(scale - 1), 0.5f * float(scale - 1));
    for (const cv::Point2f& p : corners[i]) full.emplace_back(p * float(scale) + shift);
    cv::cornerSubPix(grey, full, cv::Size(3, 3), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 60, 0.005));
    out[ids[i]] = {full[0], full[1], full[2], full[3]};
  }
  for (int id : twice) out.erase(id);
  return out;
}

void MarkerAccumulator::add(const cv::Mat& image) {
  ++frames_;
  for (const auto& [id, c] : detect_pad_markers(image, pad_)) seen_[id].push_back(c);
}

std::map<int, MarkerCorners> MarkerAccumulator::median() const {
  std::map<int, MarkerCorners> out;
  for (const auto& [id, views] : seen_) {
    MarkerCorners m;
    for (std::size_t k = 0; k < 4; ++k) {
      std::vector<float> xs, ys;
      for (const auto& v : views) xs.push_back(v[k].x), ys.push_back(v[k].y);
      std::nth_element(xs.begin(), xs.begin() + long(xs.size() / 2), xs.end());
      std::nth_element(ys.begin(), ys.begin() + long(ys.size() / 2), ys.end());
      m[k] = {xs[xs.size() / 2], ys[ys.size() / 2]};
    }
    out[id] = m;
  }
  return out;
}

Result<PadCalibration> calibrate_pad(const std::map<int, MarkerCorners>& markers, const CameraModel& intrinsics,
                                     const PadLayout& pad) {
  if (markers.size() < kMinPadMarkers) {
    std::string seen;
    for (const auto& [id, c] : markers) seen += (seen.empty() ? "" : ", ") + std::to_string(id);
    return Error{
        fmt::format("only {} of the mat's {} markers are visible (seen: {}); at least {} are needed. Check "
                    "that the mat is in view, lit, in focus, and not covered by a hand",
                    markers.size(), pad.markers.size(), seen.empty() ? "none" : seen, kMinPadMarkers)};
  }
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  PadCalibration out;
  for (const auto& [id, c] : markers) {
    const auto mm = pad.marker_corners_mm(*pad.marker(id));
    for (std::size_t k = 0; k < 4; ++k) {
      object.emplace_back(mm[k].x, mm[k].y, 0.0);
      image.emplace_back(c[k].x, c[k].y);
    }
    out.marker_ids.push_back(id);
  }
  // Solve on undistorted points with the ideal camera: the homography then holds exactly.
  const std::vector<cv::Point2d> ideal = intrinsics.undistort(image);
  cv::Vec3d rvec, tvec;
  if (!cv::solvePnP(object, ideal, intrinsics.K, cv::noArray(), rvec, tvec, false, cv::SOLVEPNP_IPPE))
    return Error{"the pad's pose could not be solved from the markers seen (are the intrinsics this camera's?)"};
  cv::solvePnPRefineLM(object, ideal, intrinsics.K, cv::noArray(), rvec, tvec);
  out.model = intrinsics;
  cv::Matx33d R;
  cv::Rodrigues(rvec, R);
  out.model.R = R;
  out.model.t = tvec;
  if (out.model.centre_mm().z >= 0)
    return Error{"the solved pose puts the camera below the pad: the markers were matched wrongly"};

  // Errors: in the image (as detected, with distortion), and on the pad (each detected corner
  // cast back onto the pad plane).
  const cv::Matx33d ideal_to_pad = out.model.pad_to_ideal().inv();
  double sum_px = 0, sum_mm = 0;
  for (std::size_t i = 0; i < object.size(); ++i) {
    const cv::Point2d p = out.model.project(object[i]);
    sum_px += (p.x - image[i].x) * (p.x - image[i].x) + (p.y - image[i].y) * (p.y - image[i].y);
    const cv::Vec3d q = ideal_to_pad * cv::Vec3d(ideal[i].x, ideal[i].y, 1.0);
    const double dx = q[0] / q[2] - object[i].x, dy = q[1] / q[2] - object[i].y;
    sum_mm += dx * dx + dy * dy;
  }
  out.rms_px = std::sqrt(sum_px / double(object.size()));
  out.rms_mm = std::sqrt(sum_mm / double(object.size()));
  out.cells_to_ideal = cells_to_ideal(out.model, pad);
  out.pad_corners_px = pad_corners_px(out.model, pad);
  return out;
}

}  // namespace pvcap::calib
