#pragma once
// The simulated scene: a Sensel Morph on a white calibration mat with four
// ArUco fiducials at known positions, on a table, seen by each camera through
// a known ground-truth homography from the sensor plane (mm) to image pixels.
//
// Sensor-plane coordinates: millimetres, origin at the centre of sensel (0,0),
// x along the 185 columns (0..230 mm), y along the 105 rows (0..130 mm).
#include <array>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace pvcap::sim {

struct Fiducial {
  int id;               // ArUco DICT_4X4_50 id
  cv::Point2d centre_mm;
  double size_mm;
};

struct PadGeometry {
  double active_w_mm = 230.0, active_h_mm = 130.0;  // 185 x 105 sensels at 1.25 mm
  double body_margin_mm = 6.0;                      // black sensor body around the active area
  cv::Rect2d mat_mm{-45.0, -45.0, 320.0, 220.0};    // the white mat carrying the fiducials
  std::vector<Fiducial> fiducials;
};
PadGeometry default_pad();

// Ground-truth homography (sensor mm -> image px) of simulated camera `index`
// for an image of `size`: four distinct, plausible viewpoints looking down.
cv::Matx33d camera_homography(int index, cv::Size size);

// Renders the scene as BGR for one camera. Deterministic.
cv::Mat render_scene_bgr(const PadGeometry& pad, const cv::Matx33d& mm_to_px, cv::Size size);

// Converts BGR to what a camera of `pixel_format` (PFNC name: BayerRG8, BayerBG8,
// BayerGB8, BayerGR8, Mono8, RGB8) would send. Bayer/Mono: CV_8UC1; RGB8: CV_8UC3 in R,G,B order.
cv::Mat to_sensor_format(const cv::Mat& bgr, const std::string& pixel_format);

// Draws the fingertip's contact disc (skin colour, darker rim) straight into a sensor-format
// image (what to_sensor_format returns), centred at `centre_px` with `radius_px`.
void draw_fingertip(cv::Mat& sensor_image, const std::string& pixel_format, cv::Point2d centre_px, double radius_px);

}  // namespace pvcap::sim
