#pragma once
// The arrival of one stream buffer's fills: stamped by Aravis' stream thread as it finishes a fill
// (its buffer-done callback), read by the consumer as it takes that fill from Aravis' queue.
//
// Aravis may queue the buffer before or after its callback (the GigE stream's order changed between
// versions: 0.8.26 queues first), so the consumer pairs its n-th take of the buffer with the n-th
// stamp, not with whatever the slot holds: the stream thread stamps a buffer's fills in order, each
// before the next fill. A stamp that has not come `wait` after the take (a stream thread preempted
// between queueing and calling back) is not waited for longer: the take is stamped with the moment
// it gave up, marked late, and the late stamp, when it comes, stays paired with that take.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <thread>

#include "core/time.h"

namespace pvcap {

class ArrivalSlot {
 public:
  struct Arrival {
    HostNs at;
    bool accepted = false;  // the stream took frames when it was finished
    bool late = false;      // not stamped in time: `at` is when the consumer gave up waiting
  };

  // Stream thread: a fill finished at `at`, while frames were (or were not) being taken.
  void stamp(HostNs at, bool accepted) {
    accepted_.store(accepted, std::memory_order_relaxed);
    ns_.store(at.ns, std::memory_order_relaxed);
    stamps_.fetch_add(1, std::memory_order_release);
  }

  // Consumer (one thread): the arrival of the fill just taken. A late one says whether `accepting`
  // holds at the moment it gives up.
  Arrival take(std::chrono::nanoseconds wait, const std::atomic<bool>& accepting) {
    const std::uint64_t nth = ++takes_;
    if (stamps_.load(std::memory_order_acquire) < nth) {
      const std::int64_t give_up = host_now().ns + wait.count();
      while (stamps_.load(std::memory_order_acquire) < nth) {
        if (const HostNs now = host_now(); now.ns > give_up) return {now, accepting.load(), true};
        std::this_thread::yield();
      }
    }
    return {HostNs{ns_.load(std::memory_order_relaxed)}, accepted_.load(std::memory_order_relaxed), false};
  }

 private:
  std::atomic<std::int64_t> ns_{0};
  std::atomic<bool> accepted_{false};
  std::atomic<std::uint64_t> stamps_{0};  // fills stamped (stream thread)
  std::uint64_t takes_ = 0;               // fills taken (consumer's thread only)
};

}  // namespace pvcap
