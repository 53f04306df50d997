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
#include <vector>

#include <opencv2/core.hpp>

#include "core/result.h"
#include "storage/video/bayer_planes.h"
#include "storage/video/bayer_tiles.h"

namespace pvcap {

struct VideoSettings {
  // Raw mode: a Bayer pattern as PFNC names it ("BayerRG8"). Frames come in as the sensor's mosaic
  // and are stored losslessly as its four planes (storage/video/bayer_planes.h) with `raw_codec`; the
  // layout, pattern and bit depth are written into the file's tags. Empty: colour mode (BGR in,
  // `codec` with `crf`, `preset` and `pixel_format`).
  std::string bayer_format;
  int bit_depth = 8;  // raw mode: bits per sample; above 8 the mosaic comes in CV_16UC1 (stored as 16-bit grey)
  // Raw mode: how the planes are stacked (storage/video/bayer_planes.h). New recordings take the second
  // green last; a re-encode keeps its source's layout, so the capture checksums still hold.
  std::string layout = kBayerPlanesGreenLastLayout;
  // Raw mode: the mosaic cut into this grid of tiles, each its own stream of the file
  // (storage/video/bayer_tiles.h), as near as the size allows; 1 x 1: one stream, as before 2026-12-07.
  int tile_cols = 1, tile_rows = 1;
  std::string raw_codec = "ffvhuff";
  // Raw mode: the raw codec's own options, FFmpeg's "key=value:key=value" ("pred=median:context=1").
  std::string raw_codec_options;
  // Raw mode with HuffYUV (ffvhuff): how often each left-prediction residual (0-255, mod 256) occurs
  // in the frames to come, for Huffman tables fitted to them, static in every stream's header (as
  // fast to decode as the default tables, which fit a noisy sensor less well). Empty: the defaults.
  std::vector<std::uint64_t> residual_counts;
  std::string codec = "libx264";
  int crf = 10;
  std::string preset = "ultrafast";
  std::string pixel_format = "yuv444p";
  int gop_frames = 15;                 // at most this many frames between key frames
  double nominal_fps = 15;             // rate-control hint only; timestamps are real
  int threads = 1;                     // per encoder; cameras already run in parallel
  std::string container = "matroska";  // FFmpeg's muxer name ("mp4" for a rendered replay)
  int width = 0, height = 0;           // the camera's image (in raw mode the mosaic, not the stacked planes)
  bool raw() const { return !bayer_format.empty(); }
  // What the file's codec is and holds, as the index records it.
  std::string stored_codec() const { return raw() ? raw_codec : codec; }
  std::string stored_pixel_format() const { return raw() ? (bit_depth > 8 ? "gray16le" : "gray") : pixel_format; }
};

class VideoWriter {
 public:
  static Result<std::unique_ptr<VideoWriter>> open(const std::filesystem::path& path, const VideoSettings& settings);
  ~VideoWriter();
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;

  // Encodes one frame at `pts_us` (µs from the session start): BGR (CV_8UC3) in colour mode, the
  // mosaic (CV_8UC1, or CV_16UC1 above 8 bits) in raw mode, of the configured size. Returns its 0-based index in the
  // file.
  Result<std::int64_t> write(const cv::Mat& image, std::int64_t pts_us);
  // Flushes the encoder and writes the trailer. Safe to call twice.
  Status close();
  std::int64_t frames_written() const { return frames_; }
  // The timestamp (ms) the last written frame carries in the file: its pts rounded to the
  // container's milliseconds, moved 1 ms on when it would not be after the one before.
  std::int64_t last_pts_ms() const { return last_pts_ms_; }
  const std::filesystem::path& path() const { return path_; }
  // Raw mode: the last frame's planes as they were handed to the codec (bayer_planes_size, stacked
  // in plane_order()), until the next write; empty before the first write and in colour mode.
  cv::Mat stored_planes() const;
  const PlaneOrder& plane_order() const { return order_; }
  // Raw mode: the grid the frames are stored in (1 x 1 when untiled).
  const TileGrid& tile_grid() const { return grid_; }

 private:
  VideoWriter() = default;
  Status encode(std::size_t tile, bool flush);
  Status end_cluster();
  Status flush_tiles();
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::filesystem::path path_;
  std::int64_t frames_ = 0;
  std::int64_t last_pts_ms_ = 0;
  bool closed_ = false;
  bool raw_ = false;
  PlaneOrder order_ = kCellOrder;  // raw mode: the planes' stacking
  TileGrid grid_;                  // raw mode: the tiles
  int input_type_ = 0;             // what write() takes
  int width_ = 0, height_ = 0;
};

}  // namespace pvcap
