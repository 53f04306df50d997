#pragma once
// The pad: the Sensel Morph's sensing grid and the fiducial mat around it, in one
// coordinate frame that the simulator draws and calibration measures (one copy).
//
// Pad frame (mm, right-handed): origin at the centre of sensor cell (col 0, row 0), x along
// the columns, y along the rows, z into the pad. Seen from above, x points right and y down
// exactly as the pressure image is drawn (row 0 at the top), so a camera above the pad has
// z < 0. Config files give heights above the pad as positive numbers (position_mm's third
// value); pad_point() turns them into this frame.
//
// Cell convention: cell (c, r) covers [c - 0.5, c + 0.5] x [r - 0.5, r + 0.5] in pressure
// image pixel coordinates (OpenCV's: an integer is a cell's centre), so the grid's outer
// edges are at -0.5 and 184.5 / 104.5. "Grid edge" coordinates (0..185, 0..105) count from
// the outer edge instead: edge = pixel + 0.5. PressureVision's loaders map pixel 0 and 185
// to the physical corners (neither convention, spec 2.1); the export converts.
#include <array>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>

namespace pvcap::calib {

struct PadMarker {
  int id = 0;             // in PadLayout::dictionary
  cv::Point2d centre_mm;  // pad frame
  double size_mm = 0;     // outer black square's side
};

struct PadLayout {
  std::string name = "pvcap-mat-v1";
  int cols = 185, rows = 105;  // the Morph's sensor grid
  double pitch_mm = 1.25;
  double body_margin_mm = 6.0;                    // black sensor body around the active area
  cv::Rect2d mat_mm{-52.0, -52.0, 334.0, 236.0};  // the white mat that carries the markers
  int dictionary = 0;                             // cv::aruco::PREDEFINED_DICTIONARY_NAME (DICT_4X4_50)
  std::vector<PadMarker> markers;

  // Pad-frame position of a pressure-image pixel coordinate (cell centres at integers).
  cv::Point2d cell_to_mm(cv::Point2d cell) const { return {cell.x * pitch_mm, cell.y * pitch_mm}; }
  cv::Point2d mm_to_cell(cv::Point2d mm) const { return {mm.x / pitch_mm, mm.y / pitch_mm}; }
  // The grid's outer corners in the pad frame, in the order of grid-edge coordinates
  // (0,0), (cols,0), (cols,rows), (0,rows).
  std::array<cv::Point2d, 4> grid_corners_mm() const;
  // A marker's corners in the pad frame, in ArUco's order (the marker image's top-left, top-right,
  // bottom-right, bottom-left), the marker drawn upright as seen from above.
  std::array<cv::Point2d, 4> marker_corners_mm(const PadMarker& m) const;
  const PadMarker* marker(int id) const;
};

// The mat pvcap's simulator draws and `pvcap calibrate board --pad` prints: ten 28 mm markers
// around the sensor (four corners, two along each long side, one at each short side), so a
// hand resting on the pad leaves most of them in view.
PadLayout default_pad_layout();

// A point at `height_mm` above the pad (config files' z) in the pad frame.
inline cv::Point3d pad_point(double x_mm, double y_mm, double height_mm) { return {x_mm, y_mm, -height_mm}; }

void to_json(nlohmann::json& j, const PadLayout& p);
void from_json(const nlohmann::json& j, PadLayout& p);

}  // namespace pvcap::calib
