#pragma once
// Keeps an Aravis fake-camera engine on time.
//
// 1. Works around a stall of the engine (0.8.26, and its master as of 2026-07): its loop computes
//    the poll timeout as (next wake - now) / 1000 in unsigned arithmetic, so when the wake instant
//    passes between the loop's check and that computation the difference wraps and the engine
//    sleeps its 100 ms maximum, missing up to three frames. It happens when the engine spins
//    through its last millisecond before a wake: measured in 1 of 8-12 frames of four replayed
//    cameras (33-100 ms late each time), as 100-133 ms gaps in a live simulated camera's frames,
//    and as triggers lost outright on a simulated trigger line. Any control packet ends the sleep,
//    and the engine then serves the overdue frame at once; so a thread watches when the next frame
//    is due and, once it is late, sends the engine a register read (what any GVCP client may send).
// 2. Optionally lends the engine's thread a real-time priority only around its frames. The engine's
//    poll timeout counts whole milliseconds, so it wakes up to 1 ms before its frame and spins the
//    rest; at a real-time priority throughout, two engines spinning keep both cores of a 2-core
//    machine from a third engine (or the Sensel emulator) whose frame is due, and it leaves up to
//    a millisecond late. Lent, the spin runs at a normal priority and only the last 0.2 ms before
//    the frame, and its sending, at the real-time one.
#include <sys/types.h>

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

namespace pvcap::sim {

class EngineKicker {
 public:
  struct LentPriority {
    std::function<std::int64_t()> due;  // when the engine's next frame is due (host ns; INT64_MAX: none)
    std::function<pid_t()> thread;      // the engine's thread id (0 until known)
    int priority = 10;                  // SCHED_FIFO priority around its frames
  };
  // `late_after`: the host instant (CLOCK_MONOTONIC ns) after which the engine at `ipv4` is late
  // with its next frame; INT64_MAX while none is expected. Called on the kicker's thread, as are
  // `lent`'s functions.
  EngineKicker(std::string ipv4, std::function<std::int64_t()> late_after, std::optional<LentPriority> lent = {});
  ~EngineKicker();
  EngineKicker(const EngineKicker&) = delete;
  EngineKicker& operator=(const EngineKicker&) = delete;

  // The lent priority begins this long before a frame is due, and ends (back to a normal
  // priority) this long before the next one: after the frame's packets are sent, before the
  // engine's poll can wake to spin.
  static constexpr std::int64_t kLendBeforeNs = 200'000, kReturnBeforeNs = 1'250'000;

 private:
  void run();
  // The engine's wake due: lends or returns the priority; the next instant to look again.
  std::int64_t lend_priority(std::int64_t now);

  const std::string ipv4_;
  const std::function<std::int64_t()> late_after_;
  const std::optional<LentPriority> lent_;
  std::optional<bool> realtime_;  // what the engine's thread was last set to (kicker's thread only)
  std::mutex mu_;
  std::condition_variable stop_cv_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace pvcap::sim
