#pragma once
// What a set of board views tells a lens fit, one rule for `pvcap calibrate intrinsics` and for the
// board session's live feedback, so that an operator who is told "covered" gets a lens:
// - which views can be used at all (tells_the_plane) and which of their corners were misread;
// - where in the image the board's corners have been (a lens is only known where the board has been);
// - how the board was tilted (a focal length is only seen in depth: views square to the camera
//   leave it free to trade against the distance).
#include <array>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "calib/charuco.h"

namespace pvcap::calib {

// A chessboard corner's place on the board (mm, the board's own plane), as OpenCV numbers them.
cv::Point2f board_corner_mm(int id, const BoardSpec& spec);

// A view that fixes the board's plane: at least kMinBoardCorners corners, each a number, and at
// least 3 of them off its fullest row and 3 off its fullest column. (One row of the board and a
// single corner of the next, a board at the image's edge, fixes nothing: its pose from the
// homography is arbitrary, and one such view sent whole fits out of the image: docs/calibration.md.)
bool tells_the_plane(const BoardView& view, const BoardSpec& spec);

// Leaves out a view's corners that do not sit where the others put the board (a corner read at
// another corner's place): a homography through the rest, by RANSAC, with room for the lens's
// bending (a third of a square). Returns how many were left out.
int drop_misread_corners(BoardView& view, const BoardSpec& spec);

class BoardCoverage {
 public:
  static constexpr int cols = 4, rows = 3;      // image regions
  static constexpr int kMinRegionCorners = 20;  // corners a region needs to count as covered
  static constexpr double kMinTiltDeg = 15.0;   // a view counts as tilted one way from here
  static constexpr int kMinTiltedViews = 3;     // views each of the four ways needs
  enum Tilt { TopNearer, BottomNearer, LeftNearer, RightNearer };

  BoardCoverage(cv::Size image_size, BoardSpec spec);
  // A usable view (tells_the_plane) adds its corners to the regions and its tilt to the tilts.
  void add(const BoardView& view);

  int views() const { return int(homographies_.size()); }
  // Corners per region, row-major (top left first).
  const std::array<int, cols * rows>& regions() const { return regions_; }
  // Views tilted at least kMinTiltDeg each way, estimated with `focal_px` (0: from the views
  // themselves, as OpenCV starts its fit; the image width when they cannot tell).
  std::array<int, 4> tilted_views(double focal_px = 0) const;
  // What is still missing, in words an operator acts on ("corners in top left (12 of 20)",
  // "views with the board's top edge nearer the camera (1 of 3)"); empty when covered.
  std::vector<std::string> missing(double focal_px = 0) const;
  // One short line for an operator: "13 views; regions 11 of 12 (short: top far right 7/20); tilts
  // 3 of 4 (short: top edge nearer 0/3)", or "covered (41 views)".
  std::string summary(double focal_px = 0) const;
  // The regions with no corner at all.
  std::vector<std::string> empty_regions() const;
  static std::string region_name(int index);  // "top far left", ...
  static const char* tilt_name(Tilt t);       // "the board's top edge nearer the camera", ...

 private:
  cv::Size size_;
  BoardSpec spec_;
  std::array<int, cols * rows> regions_{};
  std::vector<cv::Matx33d> homographies_;         // board mm -> image px, per view
  std::vector<std::vector<cv::Point3f>> object_;  // for the focal length's first guess
  std::vector<std::vector<cv::Point2f>> image_;
};

}  // namespace pvcap::calib
