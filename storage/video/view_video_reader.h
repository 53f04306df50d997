#pragma once
// A session's view videos (storage/video/view_video.h) on the reading side, for one SessionReader: each
// segment's opened on first use; one absent or unreadable is never asked again.
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>

#include <opencv2/core.hpp>

#include "storage/video/video_reader.h"

namespace pvcap {

class ViewVideoReader {
 public:
  explicit ViewVideoReader(std::filesystem::path session_dir) : dir_(std::move(session_dir)) {}
  // The frame at `ms` from the view video of the segment `segment` (file id `file_id`), at `size`
  // (empty: its own); nullopt when there is none, it lacks that frame, or it cannot be read.
  std::optional<cv::Mat> image(std::int64_t file_id, const std::string& segment, std::int64_t ms,
                               std::int64_t tolerance_ms, cv::Size size);

 private:
  static constexpr std::size_t kMaxOpen = 16;
  std::filesystem::path dir_;
  std::map<std::int64_t, std::unique_ptr<VideoReader>> open_;  // by the segment's file id
  std::set<std::int64_t> without_;                             // segments whose view video is absent or unreadable
};

}  // namespace pvcap
