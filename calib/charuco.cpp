#include "calib/charuco.h"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>

#include <fmt/format.h>
#include <opencv2/aruco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace pvcap::calib {

cv::Ptr<cv::aruco::CharucoBoard> make_board(const BoardSpec& s) {
  return cv::aruco::CharucoBoard::create(
      s.squares_x, s.squares_y, float(s.square_mm), float(s.marker_mm),
      cv::aruco::getPredefinedDictionary(cv::aruco::PREDEFINED_DICTIONARY_NAME(s.dictionary)));
}

cv::Mat board_image(const BoardSpec& s, double px_per_mm) {
  const int w = int(std::lround(s.squares_x * s.square_mm * px_per_mm));
  const int h = int(std::lround(s.squares_y * s.square_mm * px_per_mm));
  const int m = int(std::lround(s.margin_mm * px_per_mm));
  cv::Mat squares;
  make_board(s)->draw(cv::Size(w, h), squares, 0, 1);
  cv::Mat out(h + 2 * m, w + 2 * m, CV_8UC1, cv::Scalar(255));
  squares.copyTo(out(cv::Rect(m, m, w, h)));
  return out;
}

// A minimal PDF 1.4: one page of the board's size plus a little, the image drawn at its true size
// (72 points per inch), Flate-compressed grey pixels.
std::string board_pdf(const BoardSpec& s) {
  constexpr double kPxPerMm = 12.0;  // ~300 dpi
  const cv::Mat img = board_image(s, kPxPerMm);
  const double pt_per_mm = 72.0 / 25.4;
  const double page_w = (s.width_mm() + 20) * pt_per_mm, page_h = (s.height_mm() + 30) * pt_per_mm;
  const double img_w = s.width_mm() * pt_per_mm, img_h = s.height_mm() * pt_per_mm;
  uLongf packed_size = compressBound(uLong(img.total()));
  std::string packed(packed_size, '\0');
  compress2(reinterpret_cast<Bytef*>(packed.data()), &packed_size, img.data, uLong(img.total()), 9);
  packed.resize(packed_size);
  const std::string caption = fmt::format("pvcap ChArUco board {}x{}, squares {} mm, markers {} mm: print at 100 %",
                                          s.squares_x, s.squares_y, s.square_mm, s.marker_mm);
  const std::string content =
      fmt::format("q {:.3f} 0 0 {:.3f} {:.3f} {:.3f} cm /Im0 Do Q\nBT /F1 9 Tf {:.3f} {:.3f} Td ({}) Tj ET\n", img_w,
                  img_h, 10 * pt_per_mm, 20 * pt_per_mm, 10 * pt_per_mm, 8 * pt_per_mm, caption);
  std::vector<std::string> objects = {
      "<< /Type /Catalog /Pages 2 0 R >>",
      "<< /Type /Pages /Kids [3 0 R] /Count 1 >>",
      fmt::format("<< /Type /Page /Parent 2 0 R /MediaBox [0 0 {:.3f} {:.3f}] /Resources << /XObject << /Im0 4 0 R "
                  ">> /Font << /F1 6 0 R >> >> /Contents 5 0 R >>",
                  page_w, page_h),
      fmt::format("<< /Type /XObject /Subtype /Image /Width {} /Height {} /ColorSpace /DeviceGray /BitsPerComponent 8 "
                  "/Filter /FlateDecode /Length {} >>\nstream\n{}\nendstream",
                  img.cols, img.rows, packed.size(), packed),
      fmt::format("<< /Length {} >>\nstream\n{}endstream", content.size(), content),
      "<< /Type /Font /Subtype /Type1 /BaseFont /Helvetica >>",
  };
  std::string pdf = "%PDF-1.4\n";
  std::vector<std::size_t> offsets;
  for (std::size_t i = 0; i < objects.size(); ++i) {
    offsets.push_back(pdf.size());
    pdf += fmt::format("{} 0 obj\n{}\nendobj\n", i + 1, objects[i]);
  }
  const std::size_t xref = pdf.size();
  pdf += fmt::format("xref\n0 {}\n0000000000 65535 f \n", objects.size() + 1);
  for (std::size_t o : offsets) pdf += fmt::format("{:010d} 00000 n \n", o);
  pdf += fmt::format("trailer\n<< /Size {} /Root 1 0 R >>\nstartxref\n{}\n%%EOF\n", objects.size() + 1, xref);
  return pdf;
}

namespace {
// The refinement's half window: as wide as the board allows, for the more edge pixels it averages
// the less noise each corner carries, and never reaching a marker: between a chessboard corner and
// the nearest marker lies the white border around it, (square - marker) / 2, here seen at the
// median of the markers' shortest sides (a tilt shortens one side). 70 % of that border, 3-12 px:
// 7-8 px at the simulated rig's 75-95 px squares (the default 4 px measured 0.155 px RMS against
// 0.118, and principal points about twice as far off in the simulated board views).
cv::Size subpixel_window(const std::vector<std::vector<cv::Point2f>>& markers, const BoardSpec& spec) {
  std::vector<double> shortest;
  for (const auto& m : markers) {
    double s = std::numeric_limits<double>::max();
    for (std::size_t k = 0; k < m.size(); ++k) s = std::min(s, double(cv::norm(m[k] - m[(k + 1) % m.size()])));
    if (!m.empty()) shortest.push_back(s);
  }
  if (shortest.empty()) return {4, 4};
  std::nth_element(shortest.begin(), shortest.begin() + long(shortest.size() / 2), shortest.end());
  const double border_px = shortest[shortest.size() / 2] / spec.marker_mm * (spec.square_mm - spec.marker_mm) / 2;
  const int half = std::clamp(int(0.7 * border_px), 3, 12);
  return {half, half};
}
}  // namespace

BoardView detect_board(const cv::Mat& image, const BoardSpec& spec) {
  cv::Mat grey = image;
  if (image.channels() == 3) cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  const auto board = make_board(spec);
  std::vector<std::vector<cv::Point2f>> marker_corners;
  std::vector<int> marker_ids;
  cv::aruco::detectMarkers(grey, board->dictionary, marker_corners, marker_ids);
  BoardView view;
  if (marker_ids.empty()) return view;
  cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, grey, board, view.corners, view.ids);
  if (!view.corners.empty())
    cv::cornerSubPix(grey, view.corners, subpixel_window(marker_corners, spec), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 40, 0.005));
  return view;
}

namespace {

// A view the fit can use: enough corners, each a number (not one lost where it was looked for), and
// not all along one row or column of the board, which says nothing about its plane (and OpenCV's
// fit asserts on them): two of each.
bool tells_the_plane(const BoardView& v, const BoardSpec& spec) {
  if (v.corners.size() < kMinBoardCorners) return false;
  if (std::any_of(v.corners.begin(), v.corners.end(),
                  [](const cv::Point2f& p) { return !std::isfinite(p.x) || !std::isfinite(p.y); }))
    return false;
  std::set<int> board_rows, board_cols;
  for (int id : v.ids) board_rows.insert(id / (spec.squares_x - 1)), board_cols.insert(id % (spec.squares_x - 1));
  return board_rows.size() >= 2 && board_cols.size() >= 2;
}

}  // namespace

Result<Intrinsics> calibrate_intrinsics(const std::vector<BoardView>& all, cv::Size size, const BoardSpec& spec) {
  std::vector<std::vector<cv::Point2f>> corners;
  std::vector<std::vector<int>> ids;
  Intrinsics out;
  out.coverage.assign(Intrinsics::coverage_cols * Intrinsics::coverage_rows, 0);
  for (const BoardView& v : all) {
    if (!tells_the_plane(v, spec)) continue;
    // The board still since the view before (its corners within 0.02 px): the same view again, which
    // would weigh that pose twice and cost the fit time for nothing.
    if (!corners.empty() && ids.back() == v.ids) {
      bool same = true;
      for (std::size_t k = 0; k < v.corners.size() && same; ++k)
        same = cv::norm(v.corners[k] - corners.back()[k]) < 0.02;
      if (same) {
        ++out.repeated_views;
        continue;
      }
    }
    corners.push_back(v.corners);
    ids.push_back(v.ids);
    out.corners += int(v.corners.size());
    for (const cv::Point2f& p : v.corners) {
      const int cx = std::clamp(int(p.x * Intrinsics::coverage_cols / size.width), 0, Intrinsics::coverage_cols - 1);
      const int cy = std::clamp(int(p.y * Intrinsics::coverage_rows / size.height), 0, Intrinsics::coverage_rows - 1);
      ++out.coverage[std::size_t(cy * Intrinsics::coverage_cols + cx)];
    }
  }
  static const char* rows[] = {"top", "middle", "bottom"};
  static const char* cols[] = {"far left", "left", "right", "far right"};
  for (int r = 0; r < Intrinsics::coverage_rows; ++r)
    for (int c = 0; c < Intrinsics::coverage_cols; ++c)
      if (out.coverage[std::size_t(r * Intrinsics::coverage_cols + c)] == 0)
        out.empty_regions.push_back(fmt::format("{} {}", rows[r], cols[c]));
  out.views = int(corners.size());
  if (corners.size() < kMinBoardViews)
    return Error{
        fmt::format("the board was seen well (at least {} corners) in only {} frames; at least {} are needed. "
                    "Hold the board still in more places and angles, filling the view",
                    kMinBoardCorners, corners.size(), kMinBoardViews)};
  // Square pixels (every machine-vision sensor pvcap drives): fx = fy, one unknown less. OpenCV
  // keeps the ratio of the initial K's focal lengths, which it starts at 1.
  cv::Mat K = cv::Mat::eye(3, 3, CV_64F), dist, per_view, deviations;
  std::vector<cv::Mat> rvecs, tvecs;
  const cv::TermCriteria until(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-9);
  // `again`: from the fit before, not from OpenCV's fresh start (its first guess from the views'
  // homographies once led a refit without a few bad views to a 16 px RMS minimum).
  // CALIB_USE_LU: each step solves for the lens and some 50 views' poses (~300 unknowns) by LU instead of
  // SVD; the system is the normal equations plus damping (symmetric, positive definite), where both
  // give the same answer: on a 25-s board session the four cameras' K, distortion and RMS agreed to
  // 1e-8 px, and the fit's share of `pvcap calibrate intrinsics` fell from 21 s of CPU to 2.
  // Should a step's system be singular, LU gives NaN where SVD gives an answer (a CI run's camera came
  // out NaN, 2026-11-29): a fit that is not finite is made again by SVD from the same start, and one
  // that is still not finite is an error, never a lens.
  auto finite = [&](double rms) {
    return std::isfinite(rms) && cv::checkRange(K) && cv::checkRange(dist) && cv::checkRange(per_view);
  };
  auto calibrate = [&](bool again = false) {
    const int flags = cv::CALIB_FIX_ASPECT_RATIO | (again ? cv::CALIB_USE_INTRINSIC_GUESS : 0);
    const cv::Mat K0 = K.clone(), dist0 = dist.clone();
    double rms =
        cv::aruco::calibrateCameraCharuco(corners, ids, make_board(spec), size, K, dist, rvecs, tvecs, deviations,
                                          cv::noArray(), per_view, flags | cv::CALIB_USE_LU, until);
    if (finite(rms)) return rms;
    K0.copyTo(K);
    dist0.copyTo(dist);
    rms = cv::aruco::calibrateCameraCharuco(corners, ids, make_board(spec), size, K, dist, rvecs, tvecs, deviations,
                                            cv::noArray(), per_view, flags, until);
    if (!finite(rms))
      throw cv::Exception(cv::Error::StsNoConv, "the fit did not converge (not a finite lens)", __func__, __FILE__,
                          __LINE__);
    return rms;
  };
  try {
    out.rms_px = calibrate();
  } catch (const cv::Exception& e) {
    return Error{
        fmt::format("the lens could not be fitted to the board views ({}); record the board in more "
                    "places and angles",
                    e.err)};
  }
  // A view at a grazing angle or with a misread corner pulls the whole fit: views whose error is
  // well above the others' are left out and the fit made again from where it stood, until none is
  // (at most four times: a bad view a first fit absorbed can stand out only once others are gone,
  // as a 10-corner view did at 22 px after a first round).
  for (int round = 0; round < 4; ++round) {
    std::vector<double> errors(per_view.begin<double>(), per_view.end<double>());
    std::vector<double> sorted = errors;
    std::nth_element(sorted.begin(), sorted.begin() + long(sorted.size() / 2), sorted.end());
    const double limit = std::max(0.3, 2.0 * sorted[sorted.size() / 2]);
    std::vector<std::vector<cv::Point2f>> kept_corners;
    std::vector<std::vector<int>> kept_ids;
    for (std::size_t i = 0; i < errors.size(); ++i)
      if (errors[i] <= limit) kept_corners.push_back(corners[i]), kept_ids.push_back(ids[i]);
    if (kept_corners.size() == corners.size() || kept_corners.size() < kMinBoardViews) break;
    out.rejected_views += int(corners.size() - kept_corners.size());
    corners = std::move(kept_corners);
    ids = std::move(kept_ids);
    out.views = int(corners.size());
    out.corners = 0;
    for (const auto& c : corners) out.corners += int(c.size());
    try {
      out.rms_px = calibrate(/*again=*/true);
    } catch (const cv::Exception& e) {
      return Error{fmt::format("the lens could not be fitted to the board views ({})", e.err)};
    }
  }
  // One standard deviation of fx, fy, cx, cy as the fit itself estimates them.
  for (int k = 0; k < 4 && k < deviations.rows; ++k) out.deviation[std::size_t(k)] = deviations.at<double>(k);
  out.model.image_size = size;
  out.model.K = cv::Matx33d(K);
  out.model.distortion.assign(dist.begin<double>(), dist.end<double>());
  return out;
}

}  // namespace pvcap::calib
