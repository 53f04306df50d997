#include "export/pv_geometry.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace pvcap::exporting {

std::array<cv::Point2d, 4> pv_sensor_corners() { return {{{185, 0}, {185, 105}, {0, 105}, {0, 0}}}; }

std::array<cv::Point3d, 4> pv_world_corners_mm() {
  // w = 235, h = 135 mm; origin 14 mm along X, 16 mm along Z; the pad at Y = -1 mm. Columns run
  // along +Z, rows along -X (spec 2.1).
  return {{{149, -1, 251}, {14, -1, 251}, {14, -1, 16}, {149, -1, 16}}};
}

std::array<cv::Point2d, 4> loader_corners(const cv::Matx33d& K, const cv::Matx44d& mv) {
  const cv::Matx33d R(mv(0, 0), mv(0, 1), mv(0, 2), mv(1, 0), mv(1, 1), mv(1, 2), mv(2, 0), mv(2, 1), mv(2, 2));
  cv::Vec3d rvec;
  cv::Rodrigues(R, rvec);
  const cv::Vec3d tvec(mv(0, 3) / 1000, mv(1, 3) / 1000, mv(2, 3) / 1000);  // the loaders' metres
  std::vector<cv::Point3d> world;
  for (const auto& p : pv_world_corners_mm()) world.emplace_back(p.x / 1000, p.y / 1000, p.z / 1000);
  std::vector<cv::Point2d> image;
  cv::projectPoints(world, rvec, tvec, cv::Mat(K), cv::Mat(), image);
  return {image[0], image[1], image[2], image[3]};
}

PvPose fit_pv_pose(const cv::Matx33d& K, const std::array<cv::Point2d, 4>& measured) {
  const auto corners = pv_world_corners_mm();
  const std::vector<cv::Point3d> world(corners.begin(), corners.end());
  const std::vector<cv::Point2d> image(measured.begin(), measured.end());
  cv::Mat rvec, tvec;
  // Four coplanar points: the homography-based start, then Levenberg-Marquardt on the pixel error.
  cv::solvePnP(world, image, cv::Mat(K), cv::Mat(), rvec, tvec, false, cv::SOLVEPNP_ITERATIVE);
  cv::solvePnPRefineLM(world, image, cv::Mat(K), cv::Mat(), rvec, tvec);
  cv::Matx33d R;
  cv::Rodrigues(rvec, R);
  PvPose p;
  p.model_view = cv::Matx44d::eye();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) p.model_view(r, c) = R(r, c);
    p.model_view(r, 3) = tvec.at<double>(r);
  }
  p.corners = loader_corners(K, p.model_view);
  double ss = 0;
  for (int i = 0; i < 4; ++i) {
    const double d = cv::norm(p.corners[std::size_t(i)] - measured[std::size_t(i)]);
    ss += d * d;
    p.max_px = std::max(p.max_px, d);
  }
  p.rms_px = std::sqrt(ss / 4);
  return p;
}

cv::Matx33d corner_homography(const std::array<cv::Point2d, 4>& measured) {
  std::vector<cv::Point2f> from, to;
  for (const auto& p : pv_sensor_corners()) from.emplace_back(float(p.x), float(p.y));
  for (const auto& p : measured) to.emplace_back(float(p.x), float(p.y));
  return cv::Matx33d(cv::getPerspectiveTransform(from, to));
}

}  // namespace pvcap::exporting
