#pragma once
// A camera's view video: beside each lossless segment, a small colour copy of the same frames (at
// most 640 x 360, H.264, the frames' own timestamps) in the session's views/ folder. Viewers that
// show a camera at that size (the replay) read it instead of decoding the whole lossless picture,
// which is most of a replay's work (docs/performance-log.md "Replay").
//
// It is never the record: nothing is checked or exported from it, a frame missing from it (an
// encoder that was behind, a cut recording) or a view video that cannot be read is read from the
// lossless video instead, and a view video that cannot be written costs the session nothing.
#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

#include "core/result.h"
#include "storage/video/bayer_planes.h"
#include "storage/video/video_writer.h"

namespace pvcap {

inline constexpr const char* kViewFolder = "views";
inline constexpr int kViewWidth = 640, kViewHeight = 360;  // the largest view video

// The view video of a segment (its path as the index names it, relative to the session folder):
// views/<the file's name up to its first dot>.mkv, so a segment re-encoded by `pvcap compact`
// (cam0-000.x264.mkv) keeps the view of the segment it replaced (cam0-000.mkv).
std::filesystem::path view_video_path(const std::filesystem::path& segment);

// The half-size image (each Bayer cell one pixel) made as large as fits in 640 x 360 (a replay's
// view), never larger, its sides rounded down to even (H.264's 4:2:0): a 1080p camera's 640 x 360,
// a 640 x 480 camera's 320 x 240.
cv::Size view_video_size(int camera_width, int camera_height);

// The settings a camera's view video is written with (colour, libx264 ultrafast, crf 23, one
// thread); `camera` is the camera's own video settings (its size, rate and key frame interval).
VideoSettings view_video_settings(const VideoSettings& camera);

// A stored frame as its view (8-bit BGR of view_video_size), from what the camera's video was
// handed: `frame`, BGR in colour mode; in raw mode `planes`, the mosaic's planes as the raw video
// stacked them in `order` (VideoWriter::stored_planes), so the view is one pass over three of them
// (codec/demosaic.h: half size, then two thirds for a 1080p camera).
Status make_view_image(const cv::Mat& frame, const cv::Mat& planes, const PlaneOrder& order,
                       const VideoSettings& camera, cv::Mat& view);

}  // namespace pvcap
