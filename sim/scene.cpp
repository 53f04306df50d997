#include "sim/scene.h"

#include <opencv2/aruco.hpp>
#include <opencv2/imgproc.hpp>

namespace pvcap::sim {

PadGeometry default_pad() {
  PadGeometry pad;
  const double s = 28.0;
  pad.fiducials = {{0, {-22.0, -22.0}, s}, {1, {252.0, -22.0}, s}, {2, {252.0, 152.0}, s}, {3, {-22.0, 152.0}, s}};
  return pad;
}

cv::Matx33d camera_homography(int index, cv::Size size) {
  // Where the mat's corners land, as fractions of the image: top-down, from the
  // left, from the right, from the participant's side.
  static const std::array<std::array<cv::Point2f, 4>, 4> quads = {{
      {{{0.22f, 0.16f}, {0.78f, 0.16f}, {0.78f, 0.86f}, {0.22f, 0.86f}}},
      {{{0.18f, 0.22f}, {0.74f, 0.14f}, {0.80f, 0.90f}, {0.14f, 0.80f}}},
      {{{0.26f, 0.14f}, {0.82f, 0.22f}, {0.86f, 0.80f}, {0.20f, 0.90f}}},
      {{{0.28f, 0.18f}, {0.72f, 0.18f}, {0.88f, 0.88f}, {0.12f, 0.88f}}},
  }};
  const auto& q = quads[std::size_t(index) % quads.size()];
  const cv::Rect2d m = default_pad().mat_mm;
  const cv::Point2f src[4] = {{float(m.x), float(m.y)},
                              {float(m.x + m.width), float(m.y)},
                              {float(m.x + m.width), float(m.y + m.height)},
                              {float(m.x), float(m.y + m.height)}};
  cv::Point2f dst[4];
  for (int i = 0; i < 4; ++i) dst[i] = {q[i].x * float(size.width), q[i].y * float(size.height)};
  return cv::Matx33d(cv::getPerspectiveTransform(src, dst));
}

cv::Mat render_scene_bgr(const PadGeometry& pad, const cv::Matx33d& mm_to_px, cv::Size size) {
  // The table: a warm wood-like gradient with fixed-seed grain.
  cv::Mat image(size, CV_8UC3);
  for (int y = 0; y < size.height; ++y) {
    auto* row = image.ptr<cv::Vec3b>(y);
    for (int x = 0; x < size.width; ++x)
      row[x] = cv::Vec3b(cv::saturate_cast<uchar>(60 + 20 * y / size.height), cv::saturate_cast<uchar>(95 + (x % 37) / 6),
                         cv::saturate_cast<uchar>(140 + 30 * x / size.width));
  }
  cv::Mat grain(size, CV_8UC3);
  cv::RNG rng(0x5eed);
  rng.fill(grain, cv::RNG::NORMAL, 0, 6);
  image += grain;

  // The mat at 4 px/mm, drawn flat, then warped into the camera.
  constexpr double kPxPerMm = 4.0;
  const cv::Rect2d m = pad.mat_mm;
  cv::Mat mat(int(m.height * kPxPerMm), int(m.width * kPxPerMm), CV_8UC3, cv::Scalar(235, 235, 235));
  auto to_tex = [&](cv::Point2d mm) { return cv::Point2d((mm.x - m.x) * kPxPerMm, (mm.y - m.y) * kPxPerMm); };
  const cv::Point2d body_tl = to_tex({-pad.body_margin_mm, -pad.body_margin_mm});
  const cv::Point2d body_br = to_tex({pad.active_w_mm + pad.body_margin_mm, pad.active_h_mm + pad.body_margin_mm});
  cv::rectangle(mat, cv::Rect(body_tl, body_br), cv::Scalar(38, 38, 40), cv::FILLED);
  cv::rectangle(mat, cv::Rect(to_tex({0, 0}), to_tex({pad.active_w_mm, pad.active_h_mm})), cv::Scalar(70, 70, 74), 2);
  const auto dict = cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_50);
  for (const Fiducial& f : pad.fiducials) {
    const int px = int(f.size_mm * kPxPerMm);
    cv::Mat marker;
    cv::aruco::drawMarker(dict, f.id, px, marker, 1);
    cv::Mat marker_bgr;
    cv::cvtColor(marker, marker_bgr, cv::COLOR_GRAY2BGR);
    const cv::Point2d tl = to_tex({f.centre_mm.x - f.size_mm / 2, f.centre_mm.y - f.size_mm / 2});
    marker_bgr.copyTo(mat(cv::Rect(int(std::lround(tl.x)), int(std::lround(tl.y)), px, px)));
  }
  const cv::Matx33d tex_to_mm(1.0 / kPxPerMm, 0, m.x, 0, 1.0 / kPxPerMm, m.y, 0, 0, 1);
  cv::warpPerspective(mat, image, mm_to_px * tex_to_mm, size, cv::INTER_AREA, cv::BORDER_TRANSPARENT);
  return image;
}

namespace {
// Which BGR channel a Bayer sensor samples at (even row, even col), (even, odd), (odd, even), (odd, odd).
bool bayer_layout(const std::string& pf, int layout[4]) {
  if (pf == "BayerRG8") layout[0] = 2, layout[1] = 1, layout[2] = 1, layout[3] = 0;
  else if (pf == "BayerBG8") layout[0] = 0, layout[1] = 1, layout[2] = 1, layout[3] = 2;
  else if (pf == "BayerGR8") layout[0] = 1, layout[1] = 2, layout[2] = 0, layout[3] = 1;
  else if (pf == "BayerGB8") layout[0] = 1, layout[1] = 0, layout[2] = 2, layout[3] = 1;
  else return false;
  return true;
}
}  // namespace

void draw_fingertip(cv::Mat& img, const std::string& pf, cv::Point2d c, double r) {
  const cv::Vec3b skin(110, 140, 205), rim(80, 100, 160);  // BGR
  int layout[4];
  const bool bayer = bayer_layout(pf, layout);
  const int x0 = std::max(0, int(c.x - r - 1)), x1 = std::min(img.cols - 1, int(c.x + r + 1));
  const int y0 = std::max(0, int(c.y - r - 1)), y1 = std::min(img.rows - 1, int(c.y + r + 1));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const double d = std::hypot(x - c.x, y - c.y);
      if (d > r) continue;
      const cv::Vec3b col = d > 0.8 * r ? rim : skin;
      if (bayer) img.at<uchar>(y, x) = col[layout[(y & 1) * 2 + (x & 1)]];
      else if (img.type() == CV_8UC1) img.at<uchar>(y, x) = uchar((col[0] + col[1] + col[2]) / 3);
      else img.at<cv::Vec3b>(y, x) = cv::Vec3b(col[2], col[1], col[0]);  // RGB8
    }
}

cv::Mat to_sensor_format(const cv::Mat& bgr, const std::string& pixel_format) {
  if (pixel_format == "Mono8") {
    cv::Mat grey;
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
    return grey;
  }
  if (pixel_format == "RGB8") {
    cv::Mat rgb;
    cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
    return rgb;
  }
  int layout[4];
  if (!bayer_layout(pixel_format, layout)) CV_Error(cv::Error::StsBadArg, "unsupported pixel format " + pixel_format);
  cv::Mat mosaic(bgr.size(), CV_8UC1);
  for (int y = 0; y < bgr.rows; ++y) {
    const auto* in = bgr.ptr<cv::Vec3b>(y);
    auto* out = mosaic.ptr<uchar>(y);
    for (int x = 0; x < bgr.cols; ++x) out[x] = in[x][layout[(y & 1) * 2 + (x & 1)]];
  }
  return mosaic;
}

}  // namespace pvcap::sim
