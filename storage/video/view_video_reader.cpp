#include "storage/video/view_video_reader.h"

#include <spdlog/spdlog.h>

#include "storage/video/view_video.h"

namespace pvcap {

std::optional<cv::Mat> ViewVideoReader::image(std::int64_t file_id, const std::string& segment, std::int64_t ms,
                                              std::int64_t tolerance_ms, cv::Size size) {
  if (without_.count(file_id)) return std::nullopt;
  auto it = open_.find(file_id);
  if (it == open_.end()) {
    const std::filesystem::path path = dir_ / view_video_path(segment);
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) {
      without_.insert(file_id);
      return std::nullopt;
    }
    auto opened = VideoReader::open(path);
    if (!opened) {
      spdlog::warn("{} (read from the camera's own video instead)", opened.error().message);
      without_.insert(file_id);
      return std::nullopt;
    }
    if (open_.size() >= kMaxOpen) open_.erase(open_.begin());  // the earliest segment's
    it = open_.emplace(file_id, std::move(opened.value())).first;
  }
  VideoReader& view = *it->second;
  view.set_image_size(size);
  cv::Mat bgr;
  auto found = view.read_at(ms, bgr, tolerance_ms);
  if (!found) {
    spdlog::warn("{} (read from the camera's own video from here)", found.error().message);
    open_.erase(it);
    without_.insert(file_id);
    return std::nullopt;
  }
  if (!found.value() || bgr.empty()) return std::nullopt;  // not in the view: an encoder that was behind
  return bgr;
}

}  // namespace pvcap
