#pragma once
// One camera's view videos (storage/view_video.h), segment by segment, for the session writer's
// encoder thread of that camera. Any failure is said in the log and ends only the view video: the
// camera's own video never waits on it or fails with it.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

#include <opencv2/core.hpp>

#include "storage/video_writer.h"

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

 private:
  std::string camera_;
  VideoSettings settings_;  // the camera's own video's
  std::unique_ptr<VideoWriter> video_;
  cv::Mat image_;
};

}  // namespace pvcap
