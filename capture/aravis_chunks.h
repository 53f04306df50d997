#pragma once
// A frame's chunk data (GenICam chunks: the frame counter, timestamp, exposure and gain the camera
// appends to each image when chunk mode is on), read with Aravis' chunk parser under the names the
// camera's node map uses (capture/genicam_features.h). Built once per connection; reads run on the
// consumer's thread, one frame at a time, and neither block nor throw.
#include <map>
#include <memory>
#include <string>

#include <arv.h>

#include "capture/aravis_handles.h"
#include "capture/camera_frame.h"
#include "capture/genicam_features.h"
#include "core/rig_config.h"

namespace pvcap {

class AravisChunks {
 public:
  // `chunks`: the chunk value each role was enabled under (ChunkExposureTime, ChunkGainAll, ...);
  // `marks` and `exposure_us`: what the camera's stamps mark and the exposure it read back at this
  // connection (what the session's constant stamp-to-instant offset was taken from).
  // Null when there is nothing to read (no chunk enabled, or no parser).
  static std::shared_ptr<AravisChunks> create(ArvCamera* camera, std::map<CameraRole, std::string> chunks,
                                              TimestampMarks marks, double exposure_us);
  // What `buffer` carries; each value absent when the buffer has no chunks, or not that one.
  FrameChunks read(ArvBuffer* buffer) const;
  // How much later the image's instant is than the constant offset puts it, by the frame's own
  // exposure (half the difference, for stamps at the exposure's start): 0 without one.
  std::int64_t instant_correction_ns(const FrameChunks& chunks) const;

 private:
  arv::GPtr<ArvChunkParser> parser_;
  std::map<CameraRole, std::string> chunks_;
  std::map<CameraRole, bool> is_float_;  // read as a Float (exposure, an SFNC gain) or an Integer
  TimestampMarks marks_ = TimestampMarks::ExposureStart;
  double exposure_us_ = 0;
};

}  // namespace pvcap
