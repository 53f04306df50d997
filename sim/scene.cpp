#include "sim/scene.h"

#include "sim/camera_views.h"

#include <opencv2/aruco.hpp>
#include <opencv2/imgproc.hpp>

namespace pvcap::sim {

PlaneTexture pad_texture(const calib::PadLayout& pad, double px_per_mm) {
  const cv::Rect2d m = pad.mat_mm;
  cv::Mat mat(int(std::lround(m.height * px_per_mm)), int(std::lround(m.width * px_per_mm)), CV_8UC3,
              cv::Scalar(235, 235, 235));
  // Texture pixel i covers [i, i+1) / px_per_mm from the mat's edge; OpenCV puts its centre at i.
  const cv::Matx33d mm_to_tex(px_per_mm, 0, -m.x * px_per_mm - 0.5, 0, px_per_mm, -m.y * px_per_mm - 0.5, 0, 0, 1);
  auto edge = [&](cv::Point2d mm) {
    return cv::Point(int(std::lround((mm.x - m.x) * px_per_mm)), int(std::lround((mm.y - m.y) * px_per_mm)));
  };
  const auto grid = pad.grid_corners_mm();
  const cv::Point2d body(pad.body_margin_mm, pad.body_margin_mm);
  cv::rectangle(mat, cv::Rect(edge(grid[0] - body), edge(grid[2] + body)), cv::Scalar(38, 38, 40), cv::FILLED);
  cv::rectangle(mat, cv::Rect(edge(grid[0]), edge(grid[2])), cv::Scalar(70, 70, 74), 2);
  const auto dict = cv::aruco::getPredefinedDictionary(cv::aruco::PREDEFINED_DICTIONARY_NAME(pad.dictionary));
  for (const calib::PadMarker& marker : pad.markers) {
    const auto corners = pad.marker_corners_mm(marker);  // the marker image's TL, TR, BR, BL
    const cv::Point tl = edge(corners[0]), br = edge(corners[2]);
    cv::Mat drawn, drawn_bgr;
    cv::aruco::drawMarker(dict, marker.id, br.x - tl.x, drawn, 1);
    cv::cvtColor(drawn, drawn_bgr, cv::COLOR_GRAY2BGR);
    drawn_bgr.copyTo(mat(cv::Rect(tl, br)));
  }
  return {mat, mm_to_tex};
}

void draw_plane(cv::Mat& bgr, const cv::Mat& rays, const cv::Matx33d& R, const cv::Vec3d& t,
                const PlaneTexture& texture) {
  CV_Assert(rays.type() == CV_32FC2 && rays.size() == bgr.size());
  // A ray d meets the plane at X = [r1 r2 t] (u, v, 1) * s, so (u, v, 1) ~ [r1 r2 t]^-1 d, with a
  // positive last coordinate when the point lies in front of the camera.
  const cv::Matx33d plane(R(0, 0), R(0, 1), t[0], R(1, 0), R(1, 1), t[1], R(2, 0), R(2, 1), t[2]);
  const cv::Matx33d h = texture.mm_to_tex * plane.inv();
  cv::Mat map(bgr.size(), CV_32FC2);
  for (int y = 0; y < bgr.rows; ++y) {
    const auto* d = rays.ptr<cv::Vec2f>(y);
    auto* out = map.ptr<cv::Vec2f>(y);
    for (int x = 0; x < bgr.cols; ++x) {
      const double w = h(2, 0) * d[x][0] + h(2, 1) * d[x][1] + h(2, 2);
      if (w <= 1e-12) {
        out[x] = cv::Vec2f(-1e6f, -1e6f);
        continue;
      }
      out[x] = cv::Vec2f(float((h(0, 0) * d[x][0] + h(0, 1) * d[x][1] + h(0, 2)) / w),
                         float((h(1, 0) * d[x][0] + h(1, 1) * d[x][1] + h(1, 2)) / w));
    }
  }
  cv::remap(texture.bgr, bgr, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_TRANSPARENT);
}

cv::Mat render_scene_bgr(const calib::PadLayout& pad, const calib::CameraModel& camera, const cv::Mat& rays_in,
                         double noise_dn) {
  const cv::Size size = camera.image_size;
  // The table: a warm wood-like gradient with fixed-seed grain.
  cv::Mat image(size, CV_8UC3);
  for (int y = 0; y < size.height; ++y) {
    auto* row = image.ptr<cv::Vec3b>(y);
    for (int x = 0; x < size.width; ++x)
      row[x] =
          cv::Vec3b(cv::saturate_cast<uchar>(60 + 20 * y / size.height), cv::saturate_cast<uchar>(95 + (x % 37) / 6),
                    cv::saturate_cast<uchar>(140 + 30 * x / size.width));
  }
  cv::Mat grain(size, CV_8UC3);
  cv::RNG rng(0x5eed);
  rng.fill(grain, cv::RNG::NORMAL, 0, 6);
  image += grain;

  const cv::Mat rays = rays_in.empty() ? camera.normalised_rays() : rays_in;
  draw_plane(image, rays, camera.R, camera.t, pad_texture(pad));

  // A sensor's read noise, fixed per camera so frames stay cheap to make.
  if (noise_dn <= 0) return image;
  cv::Mat noise(size, CV_16SC3);
  rng.fill(noise, cv::RNG::NORMAL, 0, noise_dn);
  cv::Mat noisy;
  cv::add(image, noise, noisy, cv::noArray(), CV_8UC3);
  return noisy;
}

cv::Mat render_default_scene_bgr(int index, cv::Size size, double noise_dn) {
  return render_scene_bgr(calib::default_pad_layout(), sim_camera_model(index, SimCameraClock{}, size, size), {},
                          noise_dn);
}

namespace {
// Which BGR channel a Bayer sensor samples at (even row, even col), (even, odd), (odd, even), (odd, odd).
bool bayer_layout(const std::string& pf, int layout[4]) {
  if (pf == "BayerRG8")
    layout[0] = 2, layout[1] = 1, layout[2] = 1, layout[3] = 0;
  else if (pf == "BayerBG8")
    layout[0] = 0, layout[1] = 1, layout[2] = 1, layout[3] = 2;
  else if (pf == "BayerGR8")
    layout[0] = 1, layout[1] = 2, layout[2] = 0, layout[3] = 1;
  else if (pf == "BayerGB8")
    layout[0] = 1, layout[1] = 0, layout[2] = 2, layout[3] = 1;
  else
    return false;
  return true;
}
}  // namespace

void draw_fingertip(cv::Mat& img, const std::string& pf, cv::Point2d c, double r, double light) {
  const auto lit = [light](int b, int g, int r) {
    return cv::Vec3b(cv::saturate_cast<uchar>(b * light), cv::saturate_cast<uchar>(g * light),
                     cv::saturate_cast<uchar>(r * light));
  };
  const cv::Vec3b skin = lit(110, 140, 205), rim = lit(80, 100, 160);  // BGR
  int layout[4];
  const bool bayer = bayer_layout(pf, layout);
  const int x0 = std::max(0, int(c.x - r - 1)), x1 = std::min(img.cols - 1, int(c.x + r + 1));
  const int y0 = std::max(0, int(c.y - r - 1)), y1 = std::min(img.rows - 1, int(c.y + r + 1));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const double d = std::hypot(x - c.x, y - c.y);
      if (d > r) continue;
      const cv::Vec3b col = d > 0.8 * r ? rim : skin;
      if (bayer)
        img.at<uchar>(y, x) = col[layout[(y & 1) * 2 + (x & 1)]];
      else if (img.type() == CV_8UC1)
        img.at<uchar>(y, x) = uchar((col[0] + col[1] + col[2]) / 3);
      else
        img.at<cv::Vec3b>(y, x) = cv::Vec3b(col[2], col[1], col[0]);  // RGB8
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
