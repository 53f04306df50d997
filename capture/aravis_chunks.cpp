#include "capture/aravis_chunks.h"

#include <cmath>

namespace pvcap {

std::shared_ptr<AravisChunks> AravisChunks::create(ArvCamera* camera, std::map<CameraRole, std::string> chunks,
                                                   TimestampMarks marks, double exposure_us) {
  if (chunks.empty()) return nullptr;
  auto self = std::make_shared<AravisChunks>();
  self->marks_ = marks;
  self->exposure_us_ = exposure_us;
  self->parser_.reset(arv_camera_create_chunk_parser(camera));
  if (!self->parser_) return nullptr;
  ArvGc* genicam = arv_device_get_genicam(arv_camera_get_device(camera));
  for (const auto& [role, name] : chunks) {
    ArvGcNode* node = genicam ? arv_gc_get_node(genicam, name.c_str()) : nullptr;
    self->is_float_[role] = node && ARV_IS_GC_FLOAT(node);
  }
  self->chunks_ = std::move(chunks);
  return self;
}

FrameChunks AravisChunks::read(ArvBuffer* buffer) const {
  FrameChunks out;
  if (!arv_buffer_has_chunks(buffer)) return out;
  for (const auto& [role, name] : chunks_) {
    GError* error = nullptr;
    // An Integer is read as one: a nanosecond timestamp outgrows a double's exact range in 104 days.
    const bool real = is_float_.at(role);
    const double f = real ? arv_chunk_parser_get_float_value(parser_.get(), buffer, name.c_str(), &error) : 0;
    const std::int64_t i =
        real ? std::llround(f) : arv_chunk_parser_get_integer_value(parser_.get(), buffer, name.c_str(), &error);
    if (error) {  // not in this frame: left absent (a damaged frame is never stored as good anyway)
      g_error_free(error);
      continue;
    }
    if (role == CameraRole::ChunkFrameCounter) out.frame_counter = std::uint64_t(i);
    if (role == CameraRole::ChunkTimestamp) out.timestamp = i;
    if (role == CameraRole::ChunkExposureTime) out.exposure_us = real ? f : double(i);
    if (role == CameraRole::ChunkGain) out.gain = real ? f : double(i);
    if (role == CameraRole::ChunkLineStatus) out.line_status = i;
  }
  return out;
}

std::int64_t AravisChunks::instant_correction_ns(const FrameChunks& chunks) const {
  if (!chunks.exposure_us || *chunks.exposure_us <= 0) return 0;
  return stamp_to_mid_exposure_ns(marks_, *chunks.exposure_us) - stamp_to_mid_exposure_ns(marks_, exposure_us_);
}

}  // namespace pvcap
