#pragma once
// One camera's video file, written with FFmpeg's libraries (the libav* edge).
// Each frame carries its real timestamp (never a configured rate); no B-frames,
// parameter sets on every key frame and a GOP of at most a second, so any frame
// is one seek away; Matroska clusters are written every half second, so a crash
// loses at most the last second of video.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

#include <opencv2/core.hpp>

#include "core/result.h"

namespace pvcap {

struct VideoSettings {
  std::string codec = "libx264";
  int crf = 10;
  std::string preset = "ultrafast";
  std::string pixel_format = "yuv444p";
  int gop_frames = 15;       // at most this many frames between key frames
  double nominal_fps = 15;   // rate-control hint only; timestamps are real
  int threads = 1;           // per encoder; cameras already run in parallel
  int width = 0, height = 0;
};

class VideoWriter {
 public:
  static Result<std::unique_ptr<VideoWriter>> open(const std::filesystem::path& path, const VideoSettings& settings);
  ~VideoWriter();
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;

  // Encodes one BGR frame (CV_8UC3, the configured size) at `pts_us` (µs from the
  // session start). Returns the frame's 0-based index in the file.
  Result<std::int64_t> write(const cv::Mat& bgr, std::int64_t pts_us);
  // Flushes the encoder and writes the trailer. Safe to call twice.
  Status close();
  std::int64_t frames_written() const { return frames_; }
  // The timestamp (ms) the last written frame carries in the file: its pts rounded to the
  // container's milliseconds, moved 1 ms on when it would not be after the one before.
  std::int64_t last_pts_ms() const { return last_pts_ms_; }
  const std::filesystem::path& path() const { return path_; }

 private:
  VideoWriter() = default;
  Status encode(bool flush);
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::filesystem::path path_;
  std::int64_t frames_ = 0;
  std::int64_t last_pts_ms_ = 0;
  bool closed_ = false;
};

}  // namespace pvcap
