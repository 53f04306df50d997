#pragma once
// A camera's video settings from the rig file's store section: what the writer opens each of the
// camera's segments with, and what `pvcap recover` opens a segment it adds with.
#include <string>

#include "core/rig_config.h"
#include "storage/video/video_writer.h"

namespace pvcap {

// Raw for a Bayer `pixel_format` (PFNC name) when store.video_mode is raw, colour otherwise.
VideoSettings camera_video_settings(const StoreConfig& store, int width, int height, const std::string& pixel_format);

}  // namespace pvcap
