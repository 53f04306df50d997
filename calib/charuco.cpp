#include "calib/charuco.h"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <opencv2/aruco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/board_coverage.h"

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

namespace {
// The board's markers in a grey image, and its chessboard corners between them (to about a pixel).
BoardView find_board(const cv::Mat& grey, const BoardSpec& spec,
                     std::vector<std::vector<cv::Point2f>>& marker_corners) {
  const auto board = make_board(spec);
  std::vector<int> marker_ids;
  cv::aruco::detectMarkers(grey, board->dictionary, marker_corners, marker_ids);
  BoardView view;
  if (!marker_ids.empty())
    cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, grey, board, view.corners, view.ids);
  return view;
}

cv::Mat as_grey(const cv::Mat& image) {
  cv::Mat grey = image;
  if (image.channels() == 3) cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  return grey;
}
}  // namespace

BoardView detect_board(const cv::Mat& image, const BoardSpec& spec) {
  const cv::Mat grey = as_grey(image);
  std::vector<std::vector<cv::Point2f>> markers;
  BoardView view = find_board(grey, spec, markers);
  if (!view.corners.empty())
    cv::cornerSubPix(grey, view.corners, subpixel_window(markers, spec), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 40, 0.005));
  return view;
}

BoardView detect_board_coarse(const cv::Mat& image, const BoardSpec& spec) {
  cv::Mat half;
  cv::resize(as_grey(image), half, {}, 0.5, 0.5, cv::INTER_AREA);
  std::vector<std::vector<cv::Point2f>> markers;
  BoardView view = find_board(half, spec, markers);
  for (cv::Point2f& p : view.corners) p = p * 2.f + cv::Point2f(0.5f, 0.5f);  // half-size pixel centres
  return view;
}

namespace {

using CornerSets = std::vector<std::vector<cv::Point2f>>;
using IdSets = std::vector<std::vector<int>>;

// A lens a fit may stand on: finite, a positive focal length, and the principal point within the
// middle half of the image each way (a real lens's is within a few per cent of the centre). A fit
// outside this has wandered along a valley the views do not close, never measured a lens.
bool sensible(const cv::Mat& K, const cv::Mat& dist, cv::Size size) {
  if (K.empty() || !cv::checkRange(K) || !cv::checkRange(dist)) return false;
  const double fx = K.at<double>(0, 0), cx = K.at<double>(0, 2), cy = K.at<double>(1, 2);
  // A focal length the views leave free runs off (1e18 px once): no lens has one past 50 image widths.
  return fx > 0.1 * size.width && fx < 50.0 * size.width && std::abs(cx - size.width / 2.0) <= size.width / 4.0 &&
         std::abs(cy - size.height / 2.0) <= size.height / 4.0;
}

// OpenCV's ChArUco fit over a set of views, made so that it never returns what is not a lens.
struct LensFit {
  const CornerSets& corners;
  const IdSets& ids;
  cv::Ptr<cv::aruco::CharucoBoard> board;
  cv::Size size;
  cv::Mat K, dist, per_view, deviations;
  double rms = 0;

  // One attempt from K and dist as they stand (`guess`) or from OpenCV's fresh start (the principal
  // point at the centre, the focal length from the views' vanishing points). CALIB_USE_LU: each step
  // solves for the lens and some 50 views' poses (~300 unknowns) by LU, the normal equations plus
  // damping (symmetric, positive definite), where SVD gives the same answer 10 times slower; should a
  // step's system be singular, LU gives NaN (a CI run, 2026-11-29), so such a fit is made again by
  // SVD. True when the result is a lens (sensible); K and dist are then the fit's.
  bool attempt(int flags, bool guess, bool with_deviations = false) {
    const cv::TermCriteria until(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-9);
    // Square pixels (every machine-vision sensor pvcap drives): fx = fy, one unknown less.
    flags |= cv::CALIB_FIX_ASPECT_RATIO | (guess ? cv::CALIB_USE_INTRINSIC_GUESS : 0);
    cv::Mat K0 = guess ? K.clone() : cv::Mat::eye(3, 3, CV_64F), dist0 = guess ? dist.clone() : cv::Mat();
    for (const int solver : {int(cv::CALIB_USE_LU), 0}) {
      cv::Mat k = K0.clone(), d = dist0.clone(), pv, dev;
      std::vector<cv::Mat> rvecs, tvecs;
      try {
        // The deviations cost an inversion of the whole system (an SVD of some 500 unknowns: most of
        // a fit's time), so only the last fit asks for them.
        const double r =
            with_deviations
                ? cv::aruco::calibrateCameraCharuco(corners, ids, board, size, k, d, rvecs, tvecs, dev, cv::noArray(),
                                                    pv, flags | solver, until)
                : cv::aruco::calibrateCameraCharuco(corners, ids, board, size, k, d, rvecs, tvecs, cv::noArray(),
                                                    cv::noArray(), pv, flags | solver, until);
        if (!std::isfinite(r) || !cv::checkRange(pv) || !sensible(k, d, size)) continue;
        K = k, dist = d, per_view = pv, deviations = dev, rms = r;
        return true;
      } catch (const cv::Exception&) {
      }
    }
    return false;
  }

  // From where the fit stood when there is one, else (or when that wanders off) from the fresh
  // start, else in stages: the focal length and the first radial term with the principal point at
  // the centre, then everything from there.
  bool run() {
    if (!K.empty() && attempt(0, true)) return true;
    if (attempt(0, false)) return true;
    if (!attempt(cv::CALIB_FIX_PRINCIPAL_POINT | cv::CALIB_FIX_K2 | cv::CALIB_FIX_K3 | cv::CALIB_ZERO_TANGENT_DIST,
                 false))
      return false;
    return attempt(0, true);
  }
};

}  // namespace

Result<Intrinsics> calibrate_intrinsics(const std::vector<BoardView>& all, cv::Size size, const BoardSpec& spec) {
  CornerSets corners;
  IdSets ids;
  Intrinsics out;
  BoardCoverage coverage(size, spec);
  for (BoardView v : all) {
    if (!tells_the_plane(v, spec)) continue;
    const int misread = drop_misread_corners(v, spec);
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
    out.misread_corners += misread;
    coverage.add(v);
    corners.push_back(v.corners);
    ids.push_back(v.ids);
    out.corners += int(v.corners.size());
  }
  out.coverage.assign(coverage.regions().begin(), coverage.regions().end());
  out.empty_regions = coverage.empty_regions();
  out.views = int(corners.size());
  if (corners.size() < kMinBoardViews)
    return Error{
        fmt::format("the board was seen well (at least {} corners, over two rows and columns) in only {} frames; at "
                    "least {} are needed. Hold the board still in more places and angles, filling the view",
                    kMinBoardCorners, corners.size(), kMinBoardViews)};
  LensFit fit{corners, ids, make_board(spec), size};
  const auto lacking = [&] {
    const auto missing = coverage.missing();
    return missing.empty() ? std::string("; record the board in more places and angles")
                           : fmt::format("; the views lack {}", fmt::join(missing, ", "));
  };
  if (!fit.run())
    return Error{
        fmt::format("the lens could not be fitted to the board's {} views (no fit left the principal point "
                    "near the image's centre with a focal length a lens can have){}",
                    corners.size(), lacking())};
  // A view at a grazing angle or with a misread corner pulls the whole fit: views whose error is
  // well above the others' are left out and the fit made again from where it stood, until none is
  // (at most four times: a bad view a first fit absorbed can stand out only once others are gone,
  // as a 10-corner view did at 22 px after a first round).
  for (int round = 0; round < 4; ++round) {
    std::vector<double> errors(fit.per_view.begin<double>(), fit.per_view.end<double>());
    std::vector<double> sorted = errors;
    std::nth_element(sorted.begin(), sorted.begin() + long(sorted.size() / 2), sorted.end());
    const double limit = std::max(0.3, 2.0 * sorted[sorted.size() / 2]);
    CornerSets kept_corners;
    IdSets kept_ids;
    for (std::size_t i = 0; i < errors.size(); ++i)
      if (errors[i] <= limit) kept_corners.push_back(corners[i]), kept_ids.push_back(ids[i]);
    if (kept_corners.size() == corners.size() || kept_corners.size() < kMinBoardViews) break;
    out.rejected_views += int(corners.size() - kept_corners.size());
    corners = std::move(kept_corners);
    ids = std::move(kept_ids);
    out.views = int(corners.size());
    out.corners = 0;
    for (const auto& c : corners) out.corners += int(c.size());
    if (!fit.run())
      return Error{fmt::format("the lens could not be fitted to the board's {} views left after {} stood out{}",
                               corners.size(), out.rejected_views, lacking())};
  }
  // The fit's own standard deviations, from where it stands (it moves no further).
  if (!fit.attempt(0, true, /*with_deviations=*/true))
    return Error{fmt::format("the lens could not be fitted to the board's {} views{}", corners.size(), lacking())};
  // One standard deviation of fx, fy, cx, cy as the fit itself estimates them.
  for (int k = 0; k < 4 && k < fit.deviations.rows; ++k) out.deviation[std::size_t(k)] = fit.deviations.at<double>(k);
  // Views that cannot fix the focal length (boards square to the camera at one depth: nothing shows
  // how far away they are) leave it free, and the fit lets it run off (to 1e18 px, its deviation 0):
  // such a lens is refused, never handed on, with what the views lack.
  // (With square pixels the fit moves fy and keeps fx to it: fy's deviation is the focal length's.)
  const double f = fit.K.at<double>(1, 1), f_sd = std::max(out.deviation[0], out.deviation[1]);
  if (!(f_sd > 0) || f_sd > 0.02 * f)
    return Error{
        fmt::format("the board's {} views do not fix the focal length (the fit gives {:.4g} px, +- {:.2g}); "
                    "boards tilted towards the camera and at other distances do{}",
                    corners.size(), f, f_sd, lacking())};
  out.rms_px = fit.rms;
  out.model.image_size = size;
  out.model.K = cv::Matx33d(fit.K);
  out.model.distortion.assign(fit.dist.begin<double>(), fit.dist.end<double>());
  out.missing = coverage.missing(out.model.K(0, 0));
  return out;
}

}  // namespace pvcap::calib
