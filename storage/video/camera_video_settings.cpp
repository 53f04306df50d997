#include "storage/video/camera_video_settings.h"

#include <algorithm>

#include "codec/pixel_format.h"

namespace pvcap {

VideoSettings camera_video_settings(const StoreConfig& store, int width, int height, const std::string& pixel_format) {
  VideoSettings vs;
  if (store.video_mode == "raw" && is_bayer(pixel_format_code(pixel_format))) {
    vs.bayer_format = pixel_format;
    vs.bit_depth = bayer_bit_depth(pixel_format_code(pixel_format));
  }
  vs.raw_codec = store.raw_codec;
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
