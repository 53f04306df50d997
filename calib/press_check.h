#pragma once
// The press check: a calibration's homography against the presses themselves. For each press, the
// pressure's centroid (sensor coordinates) is compared with where the fingertip is seen in each
// camera; the disagreement, in image pixels and in mm on the pad, is what the calibration gets
// wrong where it matters (or how far the fingertip's image centre sits from its contact centre).
#include <array>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "calib/camera_model.h"
#include "calib/pad_layout.h"

namespace pvcap::calib {

// The pressure's centroid in pressure-image coordinates (cell centres at integers) of a frame on
// the device's native grid (every xscale-th, yscale-th cell), from cells above 10 % of its peak.
std::optional<cv::Point2d> pressure_centroid(const cv::Mat& native_counts, int xscale, int yscale);

// A fingertip in a camera image: the centroid of skin-coloured pixels inside the pad's outline (the
// simulated scene's fingertip; on a real rig the operator clicks it). Empty when none is seen.
std::optional<cv::Point2d> find_fingertip(const cv::Mat& bgr, const std::array<cv::Point2d, 4>& pad_corners_px);

struct PressDisagreement {
  double px = 0;  // image: fingertip seen vs the pressure centroid projected
  double mm = 0;  // pad: fingertip seen, cast onto the pad, vs the pressure centroid
};
PressDisagreement press_disagreement(const CameraModel& camera, const PadLayout& pad, cv::Point2d centroid_cells,
                                     cv::Point2d fingertip_px);

}  // namespace pvcap::calib
