#include "storage/video/view_video.h"

#include <algorithm>

#include <opencv2/imgproc.hpp>

#include "codec/demosaic.h"

namespace pvcap {

std::filesystem::path view_video_path(const std::filesystem::path& segment) {
  const std::string name = segment.filename().string();
  return segment.parent_path() / kViewFolder / (name.substr(0, name.find('.')) + ".mkv");
}

cv::Size view_video_size(int camera_width, int camera_height) {
  const double half_w = std::max(1, camera_width / 2), half_h = std::max(1, camera_height / 2);
  const double scale = std::min({1.0, kViewWidth / half_w, kViewHeight / half_h});
  auto even = [](double v) { return std::max(2, int(v + 1e-9) / 2 * 2); };
  return {even(half_w * scale), even(half_h * scale)};
}

VideoSettings view_video_settings(const VideoSettings& camera) {
  VideoSettings vs;
  vs.codec = "libx264";
  vs.crf = 23;
  vs.preset = "ultrafast";
  vs.pixel_format = "yuv420p";
  vs.gop_frames = camera.gop_frames;
  vs.nominal_fps = camera.nominal_fps;
  vs.threads = 1;
  const cv::Size size = view_video_size(camera.width, camera.height);
  vs.width = size.width;
  vs.height = size.height;
  return vs;
}

Status make_view_image(const cv::Mat& frame, const cv::Mat& planes, const PlaneOrder& order,
                       const VideoSettings& camera, cv::Mat& view) {
  const cv::Size size = view_video_size(camera.width, camera.height);
  if (!camera.raw()) {
    if (frame.type() != CV_8UC3) return Error{"a view image is made from an 8-bit colour image"};
    cv::resize(frame, view, size, 0, 0, cv::INTER_AREA);
    return {};
  }
  const int plane_rows = planes.rows / 4;
  if (planes.empty() || plane_rows * 4 != planes.rows) return Error{"no stored planes to make a view image from"};
  cv::Mat cells[4];  // in cell order: top-left, top-right, bottom-left, bottom-right
  for (int k = 0; k < 4; ++k) cells[order[std::size_t(k)]] = planes.rowRange(k * plane_rows, (k + 1) * plane_rows);
  if (Status s = scaled_half_size_from_planes(cells, camera.bayer_format, size, view); !s.ok()) return s;
  if (view.depth() != CV_8U) view.convertTo(view, CV_8U, 1.0 / double(1 << (camera.bit_depth - 8)));
  return {};
}

}  // namespace pvcap
