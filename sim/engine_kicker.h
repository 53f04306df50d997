#pragma once
// Works around a stall of Aravis' fake-camera engine (0.8.26, and its master as of 2026-07): its
// loop computes the poll timeout as (next wake - now) / 1000 in unsigned arithmetic, so when the
// wake instant passes between the loop's check and that computation the difference wraps and the
// engine sleeps its 100 ms maximum, missing up to three frames. It happens when the engine spins
// through its last millisecond before a wake: measured in 1 of 8-12 frames of four replayed cameras
// (33-100 ms late each time), as 100-133 ms gaps in a live simulated camera's frames, and as
// triggers lost outright on a simulated trigger line. Any
// control packet ends the sleep, and the engine then serves the overdue frame at once; so a thread
// watches when the next frame is due and, once it is late, sends the engine a register read (what
// any GVCP client may send).
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

namespace pvcap::sim {

class EngineKicker {
 public:
  // `late_after`: the host instant (CLOCK_MONOTONIC ns) after which the engine at `ipv4` is late
  // with its next frame; INT64_MAX while none is expected. Called on the kicker's thread.
  EngineKicker(std::string ipv4, std::function<std::int64_t()> late_after);
  ~EngineKicker();
  EngineKicker(const EngineKicker&) = delete;
  EngineKicker& operator=(const EngineKicker&) = delete;

 private:
  void run();

  const std::string ipv4_;
  const std::function<std::int64_t()> late_after_;
  std::mutex mu_;
  std::condition_variable stop_cv_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace pvcap::sim
