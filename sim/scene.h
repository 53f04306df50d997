#pragma once
// The simulated scene: a Sensel Morph on a white mat with ArUco fiducials at known
// positions (calib/pad_layout.h), on a table, seen by each camera through its pinhole model
// with lens distortion (calib/camera_model.h). Planes (the pad, a calibration board) are
// drawn by casting every pixel's ray onto them, so distortion is exact, not approximated.
#include <string>

#include <opencv2/core.hpp>

#include "calib/camera_model.h"
#include "calib/pad_layout.h"

namespace pvcap::sim {

// A flat texture and where it lies: texture pixel coordinates from plane mm (x, y).
struct PlaneTexture {
  cv::Mat bgr;
  cv::Matx33d mm_to_tex;
};
// The mat with the sensor body and the markers, at `px_per_mm`.
PlaneTexture pad_texture(const calib::PadLayout& pad, double px_per_mm = 6.0);

// Draws `texture`, lying on a plane whose frame is (R, t) in camera coordinates (its x, y axes
// R's first two columns, its origin t, mm), into `bgr` through the camera's per-pixel rays
// (CameraModel::normalised_rays()). Pixels whose ray misses the texture are left alone.
void draw_plane(cv::Mat& bgr, const cv::Mat& rays, const cv::Matx33d& R, const cv::Vec3d& t,
                const PlaneTexture& texture);

// Renders the static scene as BGR for one camera, with a fixed pattern of sensor noise (standard
// deviation in DN; 2 is a real sensor's read noise). Deterministic. `rays` may be passed when the
// caller has them already.
cv::Mat render_scene_bgr(const calib::PadLayout& pad, const calib::CameraModel& camera, const cv::Mat& rays = {},
                         double noise_dn = 2.0);
// The scene of default camera `index` (sim/camera_views.h) at `size`: for tests and benches.
cv::Mat render_default_scene_bgr(int index, cv::Size size, double noise_dn = 2.0);

// Converts BGR to what a camera of `pixel_format` (PFNC name: BayerRG8, BayerBG8,
// BayerGB8, BayerGR8, Mono8, RGB8) would send. Bayer/Mono: CV_8UC1; RGB8: CV_8UC3 in R,G,B order.
cv::Mat to_sensor_format(const cv::Mat& bgr, const std::string& pixel_format);

// Draws the fingertip's contact disc (skin colour, darker rim) straight into a sensor-format
// image (what to_sensor_format returns), centred at `centre_px` with `radius_px`, its colours
// scaled by `light` (the simulated lamps' light there, sim/lights.h; 1 without lamps).
void draw_fingertip(cv::Mat& sensor_image, const std::string& pixel_format, cv::Point2d centre_px, double radius_px,
                    double light = 1.0);

}  // namespace pvcap::sim
