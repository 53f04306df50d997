#pragma once
// The camera geometry PressureVisionDB's loaders expect (../shared/specs/pressurevision-dataset.md
// section 2.1): each camera's ModelViewMatrix (world -> camera, translation in mm) and intrinsics,
// from which the loader projects the four corners of a 235 x 135 mm pad (at fixed world points,
// without distortion) and fits the sensor-to-image homography. pvcap measures the real grid
// (185 x 105 cells at 1.25 mm: 231.25 x 131.25 mm), which no rigid pose of the loaders' larger pad
// can match exactly: the exported pose is the one that puts the loaders' corners nearest the
// measured ones, and its residual is reported.
#include <array>

#include <opencv2/core.hpp>

namespace pvcap::exporting {

// Sensor-image coordinates of the four corners in the loaders' order: (185,0), (185,105), (0,105), (0,0).
std::array<cv::Point2d, 4> pv_sensor_corners();
// The loaders' world points of those corners, in mm (world frame of the original rig; the pad in
// the Y = -1 mm plane).
std::array<cv::Point3d, 4> pv_world_corners_mm();

struct PvPose {
  cv::Matx44d model_view;              // world (mm) -> camera (mm)
  std::array<cv::Point2d, 4> corners;  // the loaders' corners in the image, pv_sensor_corners() order
  double rms_px = 0, max_px = 0;       // against the measured corners
};

// The pose that best puts the loaders' corners on `measured` (image px, pv_sensor_corners() order),
// through `K` without distortion, as the loaders project.
PvPose fit_pv_pose(const cv::Matx33d& K, const std::array<cv::Point2d, 4>& measured);

// What the loaders compute from a ModelViewMatrix and K: the four image corners and the homography
// sensor -> image (the same construction, for checking the export).
std::array<cv::Point2d, 4> loader_corners(const cv::Matx33d& K, const cv::Matx44d& model_view);

// The exact sensor -> image homography through four measured corners (PressureVision++'s per-frame
// `homography`, with `imgpts` the corners themselves).
cv::Matx33d corner_homography(const std::array<cv::Point2d, 4>& measured);

}  // namespace pvcap::exporting
