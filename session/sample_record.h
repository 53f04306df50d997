#pragma once
// The sample and clock records the store keeps, built in one place from the timeline's terms: the
// live recording (session/recording.cpp) and the end-of-session re-mapping with the final clock
// fits (session/realign.cpp) write the same record for the same frames and pairing.
#include <cstdint>
#include <vector>

#include "storage/index/records.h"
#include "sync/group_rule.h"
#include "sync/session_timeline.h"
#include "sync/timeline.h"

namespace pvcap::session {

// One camera frame of a sample, by the store's key, with its mapped time.
struct MappedCameraFrame {
  std::int64_t device_id = 0;
  std::uint32_t connection = 0;
  std::uint64_t sequence = 0;
  std::int64_t t_ns = 0;
};

// Sample `index`, serving grid tick `tick` at `tick_ns`, at the instant `at` (its cameras' group
// time, sync::group_time): each camera frame and each frame of the pressure pairing (of the
// Sensel `pressure_device_id`) with its offset from that instant.
SampleRecord sample_record(std::uint64_t index, std::int64_t tick, std::int64_t tick_ns, sync::GroupTime at,
                           const std::vector<MappedCameraFrame>& cameras, const sync::Pairing& pressure,
                           std::int64_t pressure_device_id);

// A stream's clock model at one moment (`device_id`: the stream's device in the store).
ClockModelRecord clock_record(std::int64_t device_id, const sync::ClockSnapshot& c);

}  // namespace pvcap::session
