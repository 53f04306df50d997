#pragma once
// One camera's model: intrinsics (OpenCV pinhole with the rational distortion model) and its
// pose relative to the pad frame (calib/pad_layout.h), translation in mm. The same type
// describes the simulator's ground truth and what calibration measures.
#include <array>
#include <vector>

#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>

#include "calib/pad_layout.h"

namespace pvcap::calib {

struct CameraModel {
  cv::Size image_size;
  cv::Matx33d K = cv::Matx33d::eye();
  std::vector<double> distortion;      // k1, k2, p1, p2[, k3[, k4, k5, k6]] (OpenCV's order); empty = none
  cv::Matx33d R = cv::Matx33d::eye();  // pad frame -> camera frame
  cv::Vec3d t;                         // mm

  // A camera at `position` looking at `target` (pad frame), image rows running along +y of the
  // pad as far as the view allows (the participant's side at the bottom).
  static CameraModel looking_at(cv::Size size, double focal_px, cv::Point2d principal, std::vector<double> distortion,
                                cv::Point3d position, cv::Point3d target);

  // Where a pad-frame point shows in the image (with distortion), and in the ideal image (none).
  cv::Point2d project(const cv::Point3d& pad_mm) const;
  cv::Point2d project_ideal(const cv::Point3d& pad_mm) const;
  // Homography from the pad plane (z = 0, mm) to ideal (undistorted) pixels: K [r1 r2 t].
  cv::Matx33d pad_to_ideal() const;
  // The camera's centre in the pad frame.
  cv::Point3d centre_mm() const;
  // Undistorts image pixels to ideal pixels (same K).
  std::vector<cv::Point2d> undistort(const std::vector<cv::Point2d>& pixels) const;
  // The ray through every pixel as normalised ideal coordinates (x/z, y/z): CV_32FC2 of image_size.
  cv::Mat normalised_rays() const;
  cv::Mat distortion_mat() const;
};

// Homography from pressure-image pixel coordinates (calib/pad_layout.h) to ideal image pixels.
cv::Matx33d cells_to_ideal(const CameraModel& m, const PadLayout& pad);
// The grid's outer corners in the (distorted) image, in grid_corners_mm() order.
std::array<cv::Point2d, 4> pad_corners_px(const CameraModel& m, const PadLayout& pad);

// A 3x3 matrix as the 9 numbers the calibration file writes, row by row.
std::vector<double> flat(const cv::Matx33d& m);

void to_json(nlohmann::json& j, const CameraModel& m);
void from_json(const nlohmann::json& j, CameraModel& m);

}  // namespace pvcap::calib
