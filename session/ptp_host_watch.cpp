#include "session/ptp_host_watch.h"

#include <cmath>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "capture/aravis_camera.h"
#include "core/thread_name.h"
#include "core/time.h"

namespace pvcap::session {

Result<sync::PtpHostState> check_ptp_host(const PtpRigConfig& config) {
  const std::string where = fmt::format("ptp: (line {}), ptp4l at {}", config.line, config.ptp4l_socket);
  auto state = sync::PmcClient(config.ptp4l_socket).query();
  if (!state)
    return Error{fmt::format("the host's PTP time ({}): {}\nstart ptp4l with that uds_address (docs/multihost.md), or "
                             "remove the rig file's ptp: section to record without PTP",
                             where, state.error().message)};
  if (auto why = sync::ptp_host_out_of_time(state.value(), config.max_offset_us * 1000.0))
    return Error{fmt::format("the host is not in PTP time ({}): {}: {}", where, sync::describe(state.value()), *why)};
  return state;
}

Status wait_for_ptp_lock(const std::vector<std::unique_ptr<AravisCamera>>& cameras, const PtpRigConfig& config,
                         const std::atomic<bool>& cancel) {
  const auto start = std::chrono::steady_clock::now();
  const auto give_up = start + std::chrono::duration<double>(config.lock_wait_s);
  std::vector<std::string> waiting;
  for (bool first = true;; first = false) {
    waiting.clear();
    for (const auto& cam : cameras) {
      const auto s = cam->read_ptp();
      if (!s)
        waiting.push_back(s.error().message);
      else if (!s.value().locked())
        waiting.push_back(fmt::format("{}: {}", cam->label(), s.value().describe()));
    }
    if (waiting.empty()) {
      spdlog::info("every camera locked to PTP time after {:.1f} s",
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
      return {};
    }
    if (first) spdlog::info("waiting up to {:g} s for the cameras to lock to PTP time", config.lock_wait_s);
    if (cancel.load() || std::chrono::steady_clock::now() >= give_up) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
  }
  return Error{fmt::format(
      "not locked to PTP time after {:g} s (ptp.lock_wait_s): {}\nis each camera's port on the PTP switch, and its "
      "grandmaster up? (pvcap camera check names a camera's PTP features; docs/multihost.md)",
      config.lock_wait_s, fmt::join(waiting, "; "))};
}

PtpHostWatch::PtpHostWatch(const PtpRigConfig& config, Sink sink, std::chrono::milliseconds period)
    : pmc_(config.ptp4l_socket, std::min(period, std::chrono::milliseconds(1000))),
      max_offset_ns_(config.max_offset_us * 1000.0),
      sink_(std::move(sink)),
      period_(period) {
  thread_ = std::thread([this] {
    name_this_thread("pvcap-ptp");
    run();
  });
}

PtpHostWatch::~PtpHostWatch() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

PtpHostTally PtpHostWatch::tally() const {
  std::lock_guard lock(mu_);
  return tally_;
}

void PtpHostWatch::run() {
  for (;;) {
    const auto next = std::chrono::steady_clock::now() + period_;
    read_once();
    std::unique_lock lock(mu_);
    if (wake_.wait_until(lock, next, [this] { return stopping_; })) return;
  }
}

void PtpHostWatch::read_once() {
  const auto state = pmc_.query();
  const std::int64_t at = host_now().ns;
  std::optional<std::string> problem;
  if (state) {
    const sync::PtpHostState& s = state.value();
    nlohmann::json j = {{"port_state", s.port_state},   {"clock", s.clock_identity},
                        {"grandmaster", s.grandmaster}, {"gm_present", s.gm_present},
                        {"offset_ns", s.offset_ns},     {"path_delay_ns", s.path_delay_ns},
                        {"steps_removed", s.steps_removed}};
    problem = sync::ptp_host_out_of_time(s, max_offset_ns_);
    j["in_time"] = !problem;
    sink_(EventRecord{at, "ptp_host_state", std::nullopt, j.dump()});
    std::lock_guard lock(mu_);
    ++tally_.readings;
    tally_.worst_offset_ns = std::max(tally_.worst_offset_ns, std::abs(s.offset_ns));
    tally_.grandmaster = s.grandmaster;
  } else {
    problem = state.error().message;
  }
  bool began = false, ended = false;
  {
    std::lock_guard lock(mu_);
    if (problem) {
      ++tally_.seconds_out_of_time;
      tally_.last_problem = *problem;
    }
    began = problem && !out_of_time_;
    ended = !problem && out_of_time_;
    out_of_time_ = bool(problem);
  }
  if (problem) sink_(EventRecord{at, "ptp_host_out_of_time", std::nullopt, *problem});
  if (began) spdlog::warn("the host's PTP time: {} (named each second it lasts, in the session's events)", *problem);
  if (ended) spdlog::info("the host's PTP time is back: {}", sync::describe(state.value()));
}

}  // namespace pvcap::session
