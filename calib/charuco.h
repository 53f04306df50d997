#pragma once
// The ChArUco calibration board (OpenCV's aruco module): its printed geometry, finding it in an
// image, and each camera's intrinsics from many views of it, with coverage feedback (which parts
// of the image still lack corners: a lens is only known where the board has been).
#include <array>
#include <string>
#include <vector>

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/core.hpp>

#include "calib/camera_model.h"
#include "core/result.h"

namespace pvcap::calib {

struct BoardSpec {
  int squares_x = 10, squares_y = 7;  // fits an A4 page (landscape) at 100 % with room to hold it
  double square_mm = 25.0, marker_mm = 18.0;
  double margin_mm = 12.0;                   // white around the squares
  int dictionary = cv::aruco::DICT_5X5_100;  // never confused with the mat's 4x4 markers
  double width_mm() const { return squares_x * square_mm + 2 * margin_mm; }
  double height_mm() const { return squares_y * square_mm + 2 * margin_mm; }
};

cv::Ptr<cv::aruco::CharucoBoard> make_board(const BoardSpec& spec);
// The board as printed, `px_per_mm` pixels per millimetre, margin included (grey, CV_8UC1).
cv::Mat board_image(const BoardSpec& spec, double px_per_mm);
// The board as a one-page PDF at its true size (print at 100 %, "actual size").
std::string board_pdf(const BoardSpec& spec);

struct BoardView {
  std::vector<cv::Point2f> corners;  // chessboard corners found, sub-pixel
  std::vector<int> ids;
};
BoardView detect_board(const cv::Mat& image, const BoardSpec& spec);
// The same on a half-size copy, without sub-pixel refinement (corners to about a pixel), 8 times
// faster: where the board is and how it is tilted, for the board session's live coverage.
BoardView detect_board_coarse(const cv::Mat& image, const BoardSpec& spec);

struct Intrinsics {
  CameraModel model;                  // K and distortion (k1, k2, p1, p2, k3); no pose
  double rms_px = 0;                  // OpenCV's reprojection RMS over every corner used
  int views = 0;                      // board views used
  int rejected_views = 0;             // left out: their error was far above the others'
  int repeated_views = 0;             // left out: the view before them again (the board held still)
  int corners = 0;                    // corners used
  int misread_corners = 0;            // left out of views they were found in: not where the others put the board
  std::array<double, 4> deviation{};  // the fit's own standard deviation of fx, fy, cx, cy (px)
  // Corners per image region (coverage_rows x coverage_cols, row-major), and the regions with none.
  static constexpr int coverage_cols = 4, coverage_rows = 3;
  std::vector<int> coverage;
  std::vector<std::string> empty_regions;  // "top left", "middle right", ...
  // What the views still lack by the board session's coverage rule (calib/board_coverage.h): the lens
  // was fitted, but is less sure where they are missing. Empty when covered.
  std::vector<std::string> missing;
};

// The fewest corners that make a view count, and the fewest views calibrated from.
constexpr std::size_t kMinBoardCorners = 8;
constexpr std::size_t kMinBoardViews = 8;

Result<Intrinsics> calibrate_intrinsics(const std::vector<BoardView>& views, cv::Size image_size,
                                        const BoardSpec& spec);

}  // namespace pvcap::calib
