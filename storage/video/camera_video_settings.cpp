#include "storage/video/camera_video_settings.h"

#include <algorithm>
#include <cmath>

#include "codec/pixel_format.h"

namespace pvcap {

VideoSettings camera_video_settings(const StoreConfig& store, int width, int height, const std::string& pixel_format) {
  VideoSettings vs;
  if (store.video_mode == "raw" && is_bayer(pixel_format_code(pixel_format))) {
    vs.bayer_format = pixel_format;
    vs.bit_depth = bayer_bit_depth(pixel_format_code(pixel_format));
  }
  vs.raw_codec = store.raw_codec;
  // Auto: tiles of about 240 x 180 (bench/lossless_bench "stored layouts": a 1080p paper crop then
  // decodes at 3x the speed of the whole picture, for 1 % more bytes).
  vs.tile_cols = store.raw_tile_cols > 0 ? store.raw_tile_cols : std::max(1, int(std::lround(width / 240.0)));
  vs.tile_rows = store.raw_tile_rows > 0 ? store.raw_tile_rows : std::max(1, int(std::lround(height / 180.0)));
  vs.codec = store.video_codec;
  vs.crf = store.crf;
  vs.preset = store.preset;
  vs.pixel_format = store.video_pixel_format;
  vs.width = width;
  vs.height = height;
  vs.nominal_fps = store.video_fps > 0 ? store.video_fps : 30;
  vs.gop_frames = std::max(1, int(vs.nominal_fps * store.gop_seconds_x10 / 10.0));
  return vs;
}

}  // namespace pvcap
