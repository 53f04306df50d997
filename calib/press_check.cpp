#include "calib/press_check.h"

#include <opencv2/imgproc.hpp>

namespace pvcap::calib {

std::optional<cv::Point2d> pressure_centroid(const cv::Mat& native, int xscale, int yscale) {
  CV_Assert(native.type() == CV_32F);
  double peak = 0;
  cv::minMaxLoc(native, nullptr, &peak);
  if (peak <= 0) return std::nullopt;
  double sum = 0, sx = 0, sy = 0;
  for (int r = 0; r < native.rows; ++r)
    for (int c = 0; c < native.cols; ++c) {
      const double v = native.at<float>(r, c);
      if (v < 0.1 * peak) continue;
      sum += v, sx += v * c, sy += v * r;
    }
  return cv::Point2d(sx / sum * xscale, sy / sum * yscale);
}

std::optional<cv::Point2d> find_fingertip(const cv::Mat& bgr, const std::array<cv::Point2d, 4>& corners) {
  CV_Assert(bgr.type() == CV_8UC3);
  std::vector<cv::Point> outline;
  for (const auto& p : corners) outline.emplace_back(int(std::lround(p.x)), int(std::lround(p.y)));
  cv::Mat inside(bgr.size(), CV_8UC1, cv::Scalar(0));
  cv::fillConvexPoly(inside, outline, cv::Scalar(255));
  const cv::Rect box = cv::boundingRect(outline) & cv::Rect(0, 0, bgr.cols, bgr.rows);
  double n = 0, sx = 0, sy = 0;
  for (int y = box.y; y < box.y + box.height; ++y) {
    const auto* row = bgr.ptr<cv::Vec3b>(y);
    const auto* in = inside.ptr<uchar>(y);
    for (int x = box.x; x < box.x + box.width; ++x) {
      if (!in[x]) continue;
      const cv::Vec3b c = row[x];  // B, G, R: skin is red well above blue
      if (c[2] > 150 && c[2] > c[0] + 40) n += 1, sx += x, sy += y;
    }
  }
  if (n < 12) return std::nullopt;  // a few stray pixels are not a finger
  return cv::Point2d(sx / n, sy / n);
}

PressDisagreement press_disagreement(const CameraModel& camera, const PadLayout& pad, cv::Point2d centroid_cells,
                                     cv::Point2d fingertip_px) {
  const cv::Point2d mm = pad.cell_to_mm(centroid_cells);
  PressDisagreement d;
  d.px = cv::norm(camera.project({mm.x, mm.y, 0.0}) - fingertip_px);
  const cv::Point2d ideal = camera.undistort({fingertip_px})[0];
  const cv::Vec3d q = camera.pad_to_ideal().inv() * cv::Vec3d(ideal.x, ideal.y, 1.0);
  d.mm = cv::norm(cv::Point2d(q[0] / q[2], q[1] / q[2]) - mm);
  return d;
}

}  // namespace pvcap::calib
