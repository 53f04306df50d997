#pragma once
// Reads a session video back, frame by frame, as BGR images with their
// timestamps (the libav* edge on the reading side).
#include <climits>
#include <cstdint>
#include <filesystem>
#include <memory>

#include <opencv2/core.hpp>

#include "core/result.h"

namespace pvcap {

class VideoReader {
 public:
  static Result<std::unique_ptr<VideoReader>> open(const std::filesystem::path& path);
  ~VideoReader();
  VideoReader(const VideoReader&) = delete;
  VideoReader& operator=(const VideoReader&) = delete;

  // The next frame in file order; false at the end. `pts_ms` is its timestamp.
  Result<bool> next(cv::Mat& bgr, std::int64_t& pts_ms);
  // Without decoding: the next packet of the video stream (one per frame here: no B-frames),
  // its timestamp and whether it is a key frame; false at the end. Do not mix with next().
  Result<bool> next_packet(std::int64_t& pts_ms, bool& key);
  // Random access: the frame whose timestamp is within `tolerance_ms` of `pts_ms`, decoded. Reads on
  // without seeking when that frame lies ahead in the current GOP (sequential use stays cheap),
  // otherwise seeks to the key frame before it (at most one GOP to decode). False when the
  // file holds no such frame.
  Result<bool> read_at(std::int64_t pts_ms, cv::Mat& bgr, std::int64_t tolerance_ms = 1);
  int width() const;
  int height() const;

 private:
  VideoReader() = default;
  Result<bool> decode_next(std::int64_t& pts_ms);
  void to_bgr(cv::Mat& bgr);
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::filesystem::path path_;
  std::int64_t last_pts_ms_ = INT64_MIN;  // of the frame next() returned last
};

}  // namespace pvcap
