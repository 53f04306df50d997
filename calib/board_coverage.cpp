#include "calib/board_coverage.h"

#include <algorithm>
#include <cmath>
#include <map>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <opencv2/calib3d.hpp>

namespace pvcap::calib {

cv::Point2f board_corner_mm(int id, const BoardSpec& spec) {
  const int per_row = spec.squares_x - 1;
  return {float((id % per_row + 1) * spec.square_mm), float((id / per_row + 1) * spec.square_mm)};
}

bool tells_the_plane(const BoardView& v, const BoardSpec& spec) {
  if (v.corners.size() < kMinBoardCorners || v.ids.size() != v.corners.size()) return false;
  if (std::any_of(v.corners.begin(), v.corners.end(),
                  [](const cv::Point2f& p) { return !std::isfinite(p.x) || !std::isfinite(p.y); }))
    return false;
  std::map<int, int> per_row, per_col;
  for (int id : v.ids) ++per_row[id / (spec.squares_x - 1)], ++per_col[id % (spec.squares_x - 1)];
  const auto fullest = [](const std::map<int, int>& m) {
    int most = 0;
    for (const auto& [line, n] : m) most = std::max(most, n);
    return most;
  };
  const int n = int(v.ids.size());
  return n - fullest(per_row) >= 3 && n - fullest(per_col) >= 3;
}

int drop_misread_corners(BoardView& v, const BoardSpec& spec) {
  if (v.corners.size() < 5) return 0;
  std::vector<cv::Point2f> board;
  for (int id : v.ids) board.push_back(board_corner_mm(id, spec));
  // A square's size in the image, from the corners themselves: the median distance between corners
  // a square apart on the board.
  std::vector<double> square_px;
  for (std::size_t a = 0; a < v.ids.size(); ++a)
    for (std::size_t b = a + 1; b < v.ids.size(); ++b)
      if (std::abs(cv::norm(board[a] - board[b]) - spec.square_mm) < 1e-3)
        square_px.push_back(cv::norm(v.corners[a] - v.corners[b]));
  if (square_px.empty()) return 0;
  std::nth_element(square_px.begin(), square_px.begin() + long(square_px.size() / 2), square_px.end());
  const double threshold = std::max(3.0, square_px[square_px.size() / 2] / 3);
  std::vector<unsigned char> inlier;
  const cv::Mat H = cv::findHomography(board, v.corners, cv::RANSAC, threshold, inlier, 2000, 0.999);
  if (H.empty()) return 0;
  BoardView kept;
  for (std::size_t k = 0; k < v.ids.size(); ++k)
    if (inlier[k]) kept.ids.push_back(v.ids[k]), kept.corners.push_back(v.corners[k]);
  const int dropped = int(v.ids.size() - kept.ids.size());
  v = std::move(kept);
  return dropped;
}

BoardCoverage::BoardCoverage(cv::Size image_size, BoardSpec spec) : size_(image_size), spec_(spec) {}

void BoardCoverage::add(const BoardView& v) {
  if (!tells_the_plane(v, spec_)) return;
  std::vector<cv::Point2f> board;
  std::vector<cv::Point3f> board3;
  for (int id : v.ids) {
    board.push_back(board_corner_mm(id, spec_));
    board3.emplace_back(board.back().x, board.back().y, 0.f);
  }
  const cv::Mat H = cv::findHomography(board, v.corners, 0);
  if (H.empty()) return;
  homographies_.emplace_back(H);
  object_.push_back(std::move(board3));
  image_.push_back(v.corners);
  for (const cv::Point2f& p : v.corners) {
    const int cx = std::clamp(int(p.x * cols / size_.width), 0, cols - 1);
    const int cy = std::clamp(int(p.y * rows / size_.height), 0, rows - 1);
    ++regions_[std::size_t(cy * cols + cx)];
  }
}

std::array<int, 4> BoardCoverage::tilted_views(double focal_px) const {
  std::array<int, 4> out{};
  if (homographies_.empty()) return out;
  if (!(focal_px > 0)) {
    // OpenCV's own first guess (the views' vanishing points, principal point at the centre); the
    // image width (a 53-degree view) when the views are too square to the camera to tell.
    focal_px = size_.width;
    try {
      const cv::Mat K = cv::initCameraMatrix2D(object_, image_, size_);
      const double f = K.at<double>(0, 0);
      if (std::isfinite(f) && f > 0.2 * size_.width && f < 10.0 * size_.width) focal_px = f;
    } catch (const cv::Exception&) {
    }
  }
  const cv::Matx33d K_inv = cv::Matx33d(focal_px, 0, size_.width / 2.0, 0, focal_px, size_.height / 2.0, 0, 0, 1).inv();
  const double min_tilt = std::tan(kMinTiltDeg * CV_PI / 180);
  for (const cv::Matx33d& H : homographies_) {
    const cv::Matx33d M = K_inv * H;
    cv::Vec3d r1(M(0, 0), M(1, 0), M(2, 0)), r2(M(0, 1), M(1, 1), M(2, 1));
    cv::Vec3d n = cv::normalize(r1.cross(r2));
    if (n[2] > 0) n = -n;  // the board's normal towards the camera
    // The board's top edge nearer the camera: its depth grows down the image, the normal leans up.
    const double about_x = n[1] / -n[2], about_y = n[0] / -n[2];
    if (about_x >= min_tilt) ++out[TopNearer];
    if (about_x <= -min_tilt) ++out[BottomNearer];
    if (about_y >= min_tilt) ++out[LeftNearer];
    if (about_y <= -min_tilt) ++out[RightNearer];
  }
  return out;
}

std::string BoardCoverage::region_name(int index) {
  static const char* row_names[] = {"top", "middle", "bottom"};
  static const char* col_names[] = {"far left", "left", "right", "far right"};
  return fmt::format("{} {}", row_names[index / cols], col_names[index % cols]);
}

const char* BoardCoverage::tilt_name(Tilt t) {
  switch (t) {
    case TopNearer:
      return "the board's top edge nearer the camera";
    case BottomNearer:
      return "the board's bottom edge nearer the camera";
    case LeftNearer:
      return "the board's left edge nearer the camera";
    case RightNearer:
      return "the board's right edge nearer the camera";
  }
  return "";
}

std::vector<std::string> BoardCoverage::empty_regions() const {
  std::vector<std::string> out;
  for (int i = 0; i < cols * rows; ++i)
    if (regions_[std::size_t(i)] == 0) out.push_back(region_name(i));
  return out;
}

std::string BoardCoverage::summary(double focal_px) const {
  std::vector<std::string> regions_short, tilts_short;
  for (int i = 0; i < cols * rows; ++i)
    if (regions_[std::size_t(i)] < kMinRegionCorners)
      regions_short.push_back(fmt::format("{} {}/{}", region_name(i), regions_[std::size_t(i)], kMinRegionCorners));
  static const char* tilt_short[] = {"top edge nearer", "bottom edge nearer", "left edge nearer", "right edge nearer"};
  const auto tilted = tilted_views(focal_px);
  for (int t = 0; t < 4; ++t)
    if (tilted[std::size_t(t)] < kMinTiltedViews)
      tilts_short.push_back(fmt::format("{} {}/{}", tilt_short[t], tilted[std::size_t(t)], kMinTiltedViews));
  if (regions_short.empty() && tilts_short.empty()) return fmt::format("covered ({} views)", views());
  // The first three of each: the operator moves the board there next.
  const auto first = [](const std::vector<std::string>& v) {
    std::vector<std::string> out(v.begin(), v.begin() + long(std::min<std::size_t>(v.size(), 3)));
    if (v.size() > 3) out.push_back(fmt::format("{} more", v.size() - 3));
    return fmt::format("{}", fmt::join(out, ", "));
  };
  std::string out = fmt::format("{} views; regions {} of {}", views(), cols * rows - int(regions_short.size()), cols * rows);
  if (!regions_short.empty()) out += fmt::format(" (short: {})", first(regions_short));
  out += fmt::format("; tilts {} of 4", 4 - int(tilts_short.size()));
  if (!tilts_short.empty()) out += fmt::format(" (short: {})", first(tilts_short));
  return out;
}

std::vector<std::string> BoardCoverage::missing(double focal_px) const {
  std::vector<std::string> out;
  for (int i = 0; i < cols * rows; ++i)
    if (regions_[std::size_t(i)] < kMinRegionCorners)
      out.push_back(fmt::format("corners in the image's {} ({} of {})", region_name(i), regions_[std::size_t(i)],
                                kMinRegionCorners));
  const auto tilted = tilted_views(focal_px);
  for (int t = 0; t < 4; ++t)
    if (tilted[std::size_t(t)] < kMinTiltedViews)
      out.push_back(fmt::format("views tilted {:.0f} degrees or more with {} ({} of {})", kMinTiltDeg,
                                tilt_name(Tilt(t)), tilted[std::size_t(t)], kMinTiltedViews));
  return out;
}

}  // namespace pvcap::calib
