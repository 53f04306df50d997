#pragma once
// One camera's view videos (storage/video/view_video.h), segment by segment, for the session writer's
// encoder thread of that camera. Any failure is said in the log and ends only the view video: the
// camera's own video never waits on it or fails with it. The first is kept (failure()): a disk that
// fails a view's write is failing, and the session ends saying so.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "storage/video/video_writer.h"

namespace pvcap {

class ViewVideoWriter {
 public:
  ViewVideoWriter(std::string camera, VideoSettings camera_settings)
      : camera_(std::move(camera)), settings_(std::move(camera_settings)) {}
  // The view video at `path` (closing the one before); without one when it cannot be opened.
  void open(const std::filesystem::path& path);
  bool is_open() const { return video_ != nullptr; }
  // The frame `lossless` was just handed (`frame`, or in raw mode its stored planes), as its view.
  void write(const cv::Mat& frame, const VideoWriter& lossless, std::int64_t pts_us);
  void close();
  // After a storage failure: the open view video is removed (on a full disk its space is what the
  // lossless videos and the index need to finish; its trailer may fail to be written first).
  void drop();
  // The first failure of a view video of this camera (its file and the error), if any.
  const std::optional<std::string>& failure() const { return failure_; }

 private:
  void note(const std::string& why) {
    if (!failure_) failure_ = why;
  }
  std::string camera_;
  VideoSettings settings_;  // the camera's own video's
  std::unique_ptr<VideoWriter> video_;
  cv::Mat image_;
  std::optional<std::string> failure_;
};

}  // namespace pvcap
