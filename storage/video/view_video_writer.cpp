#include "storage/video/view_video_writer.h"

#include <spdlog/spdlog.h>

#include "storage/video/view_video.h"

namespace pvcap {

void ViewVideoWriter::open(const std::filesystem::path& path) {
  close();
  std::error_code ec;
  std::filesystem::create_directories(path.parent_path(), ec);
  auto video = VideoWriter::open(path, view_video_settings(settings_));
  if (!video) {
    spdlog::warn("{}: no view video for the replay ({}); the camera's video is not affected", camera_,
                 video.error().message);
    note(video.error().message);
    return;
  }
  video_ = std::move(video.value());
}

void ViewVideoWriter::write(const cv::Mat& frame, const VideoWriter& lossless, std::int64_t pts_us) {
  if (!video_) return;
  Status s = make_view_image(frame, lossless.stored_planes(), lossless.plane_order(), settings_, image_);
  if (s.ok()) {
    if (auto w = video_->write(image_, pts_us); !w) s = w.error();
  }
  if (!s.ok()) {
    spdlog::warn(
        "{}: its view video stops here until the next segment ({}); the camera's video is not affected, "
        "the replay reads it instead",
        camera_, s.error().message);
    note(s.error().message);
    close();
  }
}

void ViewVideoWriter::close() {
  if (!video_) return;
  if (Status s = video_->close(); !s.ok()) {
    spdlog::warn("{}: its view video may be cut short ({}); the replay reads the camera's video where it is", camera_,
                 s.error().message);
    note(s.error().message);
  }
  video_.reset();
}

void ViewVideoWriter::drop() {
  if (!video_) return;
  const std::filesystem::path path = video_->path();
  video_.reset();
  std::error_code ec;
  std::filesystem::remove(path, ec);
  spdlog::info("{}: its view video stopped with the storage failure (the replay reads the camera's video)", camera_);
}

}  // namespace pvcap
