#include "sim/engine_kicker.h"

#include <pthread.h>
#include <sched.h>
#include <sys/prctl.h>

#include <algorithm>
#include <chrono>
#include <climits>

#include "capture/gvcp_ping.h"
#include "core/time.h"

namespace pvcap::sim {

EngineKicker::EngineKicker(std::string ipv4, std::function<std::int64_t()> late_after, std::optional<LentPriority> lent)
    : ipv4_(std::move(ipv4)), late_after_(std::move(late_after)), lent_(std::move(lent)), thread_([this] { run(); }) {}

EngineKicker::~EngineKicker() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  stop_cv_.notify_all();
  thread_.join();
}

std::int64_t EngineKicker::lend_priority(std::int64_t now) {
  const pid_t tid = lent_->thread();
  const std::int64_t due = lent_->due();
  if (tid <= 0 || due == INT64_MAX) return INT64_MAX;
  auto set = [&](bool realtime) {
    if (realtime_ == realtime) return;
    sched_param p{};
    p.sched_priority = realtime ? lent_->priority : 0;
    // Refused without the permission (the engine then runs at a normal priority throughout).
    (void)sched_setscheduler(tid, realtime ? SCHED_FIFO : SCHED_OTHER, &p);
    realtime_ = realtime;
  };
  if (now >= due - kLendBeforeNs) {
    set(true);
    return INT64_MAX;  // until the frame has left (the late check looks then)
  }
  // Only from this instant on: earlier, the engine may still be sending its last frame.
  if (now >= due - kReturnBeforeNs) {
    set(false);
    return due - kLendBeforeNs;
  }
  return due - kReturnBeforeNs;
}

void EngineKicker::run() {
  // Above the engines' real-time priority where allowed (sim/replay_camera.cpp), so a late frame
  // is noticed, and a priority lent, on time on a busy machine.
  sched_param rt{};
  rt.sched_priority = 11;
  (void)pthread_setschedparam(pthread_self(), SCHED_FIFO, &rt);
  prctl(PR_SET_TIMERSLACK, 1UL, 0, 0, 0);  // its waits end when asked, not up to 50 us later
  std::unique_lock lock(mu_);
  auto pause = [&](std::int64_t ns) { stop_cv_.wait_for(lock, std::chrono::nanoseconds(ns), [&] { return stop_; }); };
  while (!stop_) {
    const std::int64_t now = host_now().ns;
    std::int64_t next_look = now + 5'000'000;  // then look again in any case: the schedule may have moved
    if (lent_) next_look = std::min(next_look, lend_priority(now));
    const std::int64_t late_after = late_after_();
    if (late_after != INT64_MAX && now >= late_after) {
      lock.unlock();
      (void)gvcp_answers(ipv4_, std::chrono::milliseconds(20));
      lock.lock();
      pause(2'000'000);  // once per 2 ms while it stays late
      continue;
    }
    next_look = std::min(next_look, late_after);
    pause(std::max<std::int64_t>(next_look - now, 10'000));
  }
}

}  // namespace pvcap::sim
