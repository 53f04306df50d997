#pragma once
// The GenICam timestamp latch real GigE cameras offer (SFNC `TimestampControlLatch` +
// `TimestampLatchValue`), which Aravis' fake camera lacks, for every simulated camera
// (sim_camera.h, replay_camera.h): the fake cameras serve their GenICam XML with the two
// features added, and one thread for all of them latches each device clock when its command
// register is set, within 0.2 ms (the host polls the value until it changes).
#include <cstdint>
#include <functional>

#include "capture/aravis_handles.h"

namespace pvcap::sim {

inline constexpr std::uint32_t kLatchCommandRegister = 0xF000;
inline constexpr std::uint32_t kLatchValueRegister = 0xF008;  // 64 bits: high word, then low

// Makes the fake cameras created after this call serve the GenICam XML with the latch (once per
// process; Aravis reads the file name when each fake camera is made).
void install_latch_genicam();

// The device clock of a simulated camera: its time at a host instant (CLOCK_MONOTONIC ns).
using DeviceClock = std::function<std::int64_t(std::int64_t host_ns)>;

// Serves `fake`'s latch with `clock` until remove_latch(owner); after remove_latch returns,
// neither `fake` nor `clock` is touched again.
void add_latch(const void* owner, ArvFakeCamera* fake, DeviceClock clock);
void remove_latch(const void* owner);

}  // namespace pvcap::sim
