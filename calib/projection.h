#pragma once
// Pressure in camera images, as replay and export need it, with PressureVision's own definitions
// (../shared/specs/pressurevision-dataset.md section 2): warping a pressure frame into a camera
// image, the paper's crop applied identically to image and pressure, and the area each image
// pixel covers on the pad, so that totals (newtons) survive the warp.
#include <array>

#include <opencv2/core.hpp>

#include "calib/camera_model.h"
#include "calib/pad_layout.h"

namespace pvcap::calib {

// A pressure image (CV_32F on the sensor grid, cell centres at integer coordinates) in an image of
// `size` through `cells_to_image`: bilinear, zero off the pad (cv::warpPerspective, as PV does).
// This interpolates pressure; it does not conserve force (see pixel_area_mm2).
cv::Mat warp_pressure(const cv::Mat& pressure, const cv::Matx33d& cells_to_image, cv::Size size);

// The same into the camera's real (distorted) image: every pixel's ray is followed to the pad, so
// the overlay lies on the pad even where the lens bends it. Built once per camera, applied per frame.
class PressureProjector {
 public:
  PressureProjector(const CameraModel& camera, const PadLayout& pad);
  cv::Mat project(const cv::Mat& pressure) const;  // CV_32F of the camera's image size
  // project() over footprint() only (CV_32F of its size; all a pressure image of the pad's grid can
  // reach): for a display that draws nothing elsewhere, without zeroing the rest of a view each frame.
  cv::Mat project_footprint(const cv::Mat& pressure) const;
  // The same projection for the image shown at another size (a scaled view): each view pixel takes
  // the ray of the image point at its centre. For display: its map is fixed-point (1/32 cell), which
  // remaps about twice as fast.
  PressureProjector scaled(cv::Size view) const;
  // The part of the image a pressure image of the pad's grid can reach (project() is zero outside
  // it): the pad's footprint with a cell of margin. project() resamples only there.
  cv::Rect footprint() const { return footprint_; }

 private:
  PressureProjector() = default;
  void find_footprint();
  void resample(const cv::Mat& pressure, cv::Rect where, cv::Mat& out) const;  // out: where's size
  cv::Mat map_;                         // CV_32FC2: image pixel -> pressure-image coordinates (outside: -1e6)
  cv::Mat fixed_map_, fixed_fraction_;  // scaled(): map_ as cv::convertMaps makes it, CV_16SC2 + CV_16UC1
  cv::Size cells_;                      // the pad's grid (columns x rows)
  cv::Rect footprint_;
};

// The area on the pad (mm^2) each image pixel covers under `cells_to_image` (CV_32F of `size`;
// 0 where the pixel is off the pad): sum(kPa * area_mm2) / 1000 is force in newtons.
cv::Mat pixel_area_mm2(const cv::Matx33d& cells_to_image, cv::Size size, const PadLayout& pad);
// Force (N) of a pressure image in kPa on the sensor grid.
double sensor_force_n(const cv::Mat& pressure_kpa, const PadLayout& pad);
// The area (mm^2) through which each cell's pressure reaches images under `cells_to_image`: the
// sum, over every pixel of the pad's whole footprint (inside a given image or not), of the pixel's
// area times the cell's bilinear weight in it, at remap's fixed-point precision. About the cell's
// own area (pitch^2) where pixels are small against cells; it differs where they sample coarsely.
cv::Mat cell_reach_mm2(const cv::Matx33d& cells_to_image, const PadLayout& pad);
// warp_pressure, rescaled so that the force it puts over the pad's whole footprint equals the
// sensor's: for totals and force-weighted metrics. The scale depends on the pressure and the
// homography, never on how much of the pad the image holds, so warping into a crop equals cropping
// the warp into a larger image, and a crop holds the force inside it, not the pad's. Zero stays zero.
cv::Mat warp_pressure_conserving(const cv::Mat& pressure_kpa, const cv::Matx33d& cells_to_image, cv::Size size,
                                 const PadLayout& pad);
// The same for many frames through one map: the pixels' areas, the cells' reach and where each
// pixel samples the pressure image are computed once (a 1080p area map costs ~100 ms; a frame's
// warp into a 480x384 crop then ~0.5 ms). Bilinear as warpPerspective, at its fixed-point precision
// (1/32 cell).
class ConservingWarp {
 public:
  ConservingWarp(const cv::Matx33d& cells_to_image, cv::Size size, const PadLayout& pad);
  // `force_n`, when given, receives the sensor's force (N), which the warp conserves over the pad.
  cv::Mat operator()(const cv::Mat& pressure_kpa, double* force_n = nullptr) const;
  // The force (N) an output of operator() holds inside this image: the sensor's where the image
  // holds the whole pad, the part on its pixels where it holds part of it.
  double force_in_image_n(const cv::Mat& warped) const;

 private:
  PadLayout pad_;
  cv::Mat area_mm2_;
  cv::Mat reach_mm2_;       // cell_reach_mm2, CV_32F on the pad's grid
  cv::Mat map_, fraction_;  // image pixel -> pressure-image coordinates, as cv::convertMaps makes them
};

// A level image (CV_8U, 0-255) in OpenCV's inferno colormap (BGR). The table is built once: a named
// cv::applyColorMap rebuilds it on every call (0.3 ms here, whatever the image's size).
cv::Mat inferno(const cv::Mat& level);

// Pressure drawn over a camera image (BGR): a perceptual colormap (inferno, black = no pressure)
// blended in where the pressure is above zero, fading in over the lowest tenth of the scale so
// the faint tails of the interpolation do not paint a dark halo; untouched where it is zero.
// `full_scale` is the pressure at the colormap's top (same unit as `pressure_in_image`, CV_32F of
// the image's size, e.g. PressureProjector::project's output).
cv::Mat overlay_pressure(const cv::Mat& bgr, const cv::Mat& pressure_in_image, double full_scale,
                         double opacity = 0.75);

// The paper's crop (PressureVision recording/sequence_reader.py crop_img): the bounding box of the
// pad's four image corners, `margin` px wider on every side, grown about its rounded centre to the
// network's aspect (480:384), truncated to integers and clamped to the image (which can break the
// aspect near a border, as the original does).
cv::Rect paper_crop_box(const std::array<cv::Point2d, 4>& pad_corners, cv::Size image, double margin = 50,
                        cv::Size network = {480, 384});
// Crops and resizes (bilinear) to `network`: the same call for a camera image and for its warped pressure.
cv::Mat apply_crop(const cv::Mat& image, const cv::Rect& box, cv::Size network = {480, 384});

}  // namespace pvcap::calib
