#pragma once
// Measuring where the pad lies in one camera's view: detect the mat's ArUco markers in one
// or more frames (a median over frames keeps image noise and a passing hand out), solve the
// pad's pose with the camera's intrinsics (undistorting), and derive what replay and export
// use: the cell -> image homography and the grid's corners in the image.
#include <array>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "calib/camera_model.h"
#include "calib/pad_layout.h"
#include "core/result.h"

namespace pvcap::calib {

// One marker's corners in one image, ArUco's order, refined to sub-pixel.
using MarkerCorners = std::array<cv::Point2f, 4>;
std::map<int, MarkerCorners> detect_pad_markers(const cv::Mat& image, const PadLayout& pad);

// Markers seen over several frames of one camera.
class MarkerAccumulator {
 public:
  explicit MarkerAccumulator(const PadLayout& pad) : pad_(pad) {}
  void add(const cv::Mat& image);
  // Per marker: the median of each corner over the frames that saw it.
  std::map<int, MarkerCorners> median() const;
  int frames() const { return frames_; }

 private:
  PadLayout pad_;
  int frames_ = 0;
  std::map<int, std::vector<MarkerCorners>> seen_;
};

struct PadCalibration {
  CameraModel model;                          // the intrinsics given, with the measured pose
  cv::Matx33d cells_to_ideal;                 // pressure-image pixels -> undistorted image pixels
  std::array<cv::Point2d, 4> pad_corners_px;  // grid edges (0,0),(185,0),(185,105),(0,105), as imaged
  double rms_px = 0;                          // marker corners: reprojection error
  double rms_mm = 0;                          // the same, measured on the pad
  std::vector<int> marker_ids;                // the markers used
};

// The fewest markers a pose is solved from: three keep one badly detected marker from tilting it.
constexpr std::size_t kMinPadMarkers = 3;

// Solves the pad's pose from `markers` seen by a camera with `intrinsics` (its K, distortion and
// image size are used). An Error says what was missing and what to do.
Result<PadCalibration> calibrate_pad(const std::map<int, MarkerCorners>& markers, const CameraModel& intrinsics,
                                     const PadLayout& pad);

}  // namespace pvcap::calib
