#pragma once
// When a Sensel Morph answers. Shared by the emulator's two transports (the
// pseudo-terminal and the emulated USB device) so both pace alike: a frame read
// waits for the scan to finish (8 ms per scan at medium detail; at high detail
// 19.6 ms plus 12.5 us per payload byte, the spec's measured floor and slope,
// §9), then reaches the host after a random USB delay; register traffic is
// answered at once.
#include <cstdint>
#include <random>
#include <span>
#include <vector>

#include "sim/sensel_emulator.h"

namespace pvcap::sim {

struct SenselLink {
  double jitter_mean_ms = 0;  // USB arrival delay after the scan: exponential with this mean...
  double jitter_max_ms = 0;   // ...capped here (a long tail, not an unbounded one)
  std::uint64_t seed = 1;
};

struct PacedAnswer {
  std::vector<std::uint8_t> bytes;
  std::int64_t deliver_at_ns = 0;  // host CLOCK_MONOTONIC
  bool replayed = false;           // a recorded frame (SenselEmulator::replay_sent() after it left)
};

// The longest a replayed frame read is held for its frame (below the driver's 0.5 s timeout).
inline constexpr std::int64_t kReplayHoldNs = 350'000'000;

class SenselPacer {
 public:
  SenselPacer(SenselEmulator& emulator, SenselLink link);
  // Feeds `request` (arriving at `now_ns`) to the emulator. A frame is scanned at the
  // instant its scan completes (possibly after `now_ns`) and stamped with it.
  PacedAnswer answer(std::span<const std::uint8_t> request, std::int64_t now_ns);

 private:
  SenselEmulator& emu_;
  SenselLink link_;
  std::int64_t next_scan_ns_ = 0;
  std::mt19937_64 rng_;
  std::exponential_distribution<double> usb_delay_ms_;
};

}  // namespace pvcap::sim
