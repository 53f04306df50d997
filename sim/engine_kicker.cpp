#include "sim/engine_kicker.h"

#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <chrono>
#include <climits>

#include "capture/gvcp_ping.h"
#include "core/time.h"

namespace pvcap::sim {

EngineKicker::EngineKicker(std::string ipv4, std::function<std::int64_t()> late_after)
    : ipv4_(std::move(ipv4)), late_after_(std::move(late_after)), thread_([this] { run(); }) {}

EngineKicker::~EngineKicker() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  stop_cv_.notify_all();
  thread_.join();
}

void EngineKicker::run() {
  // Above the engines' real-time priority where allowed (sim/replay_camera.cpp), so a late frame
  // is noticed on time on a busy machine.
  sched_param rt{};
  rt.sched_priority = 11;
  (void)pthread_setschedparam(pthread_self(), SCHED_FIFO, &rt);
  std::unique_lock lock(mu_);
  auto pause = [&](std::int64_t ns) { stop_cv_.wait_for(lock, std::chrono::nanoseconds(ns), [&] { return stop_; }); };
  while (!stop_) {
    const std::int64_t late_after = late_after_();
    const std::int64_t now = host_now().ns;
    if (late_after == INT64_MAX) {
      pause(5'000'000);
    } else if (now < late_after) {
      pause(std::min<std::int64_t>(late_after - now, 5'000'000));  // then look again: it may have moved
    } else {
      lock.unlock();
      (void)gvcp_answers(ipv4_, std::chrono::milliseconds(20));
      lock.lock();
      pause(2'000'000);  // once per 2 ms while it stays late
    }
  }
}

}  // namespace pvcap::sim
