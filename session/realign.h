#pragma once
// The last step of a recording: every frame re-mapped with its stream's final clock
// fit (the online fit each frame met was fitted on less), then every sample's instant
// and pressure pairing recomputed. Which frames are in the videos is not revisited;
// that was decided online, within half a frame period, which the final fit does not
// change.
#include <cstdint>
#include <vector>

#include "storage/session_index.h"
#include "sync/session_timeline.h"

namespace pvcap {

struct RealignInput {
  std::vector<sync::SessionTimeline::StreamClocks> clocks;
  std::vector<std::int64_t> camera_device_ids;  // by camera index
  std::int64_t pressure_device_id = 0;
  std::int64_t max_offset_ns = 20'000'000;
};

struct RealignResult {
  std::size_t samples = 0;
};

RealignResult realign(SessionIndex& index, const RealignInput& in);

}  // namespace pvcap
