#include "capture/camera_watchdog.h"

#include <fmt/format.h>

namespace pvcap {

void CameraWatchdog::started(HostNs at) {
  started_at_ = at;
  underruns_seen_ = 0;  // a new stream counts from zero
  underrun_at_ = HostNs{0};
  unanswered_ = 0;
  said_no_trigger_ = false;
}

CameraWatchdog::Look CameraWatchdog::look(HostNs now, HostNs last_frame, std::uint64_t underruns, bool control_lost) {
  if (underruns > underruns_seen_) underrun_at_ = now;
  underruns_seen_ = underruns;
  HostNs last = std::max(last_frame, underrun_at_);
  const bool first_frame_pending = last.ns == 0 || last < started_at_;
  if (first_frame_pending) last = started_at_;
  Look out;
  out.silent_ms = (now.ns - last.ns) / 1'000'000;
  const auto limit = first_frame_pending ? config_.first_frame_timeout : config_.stall_timeout;
  bool stalled = out.silent_ms > limit.count();
  if (config_.on_trigger_line) {
    if (!config_.can_ask || !stalled) {
      unanswered_ = 0;
      if (!stalled) said_no_trigger_ = false;
    } else if (now.ns - last_ask_.ns >= std::chrono::nanoseconds(config_.ask_every).count()) {
      last_ask_ = now;
      out.verdict = Verdict::Ask;
    }
    stalled = unanswered_ >= config_.unanswered_limit;
  }
  if (control_lost) {
    out.verdict = Verdict::Lost;
    out.why = "control channel lost";
  } else if (stalled) {
    out.verdict = Verdict::Lost;
    out.why =
        fmt::format("no frame for {} ms{}", out.silent_ms, config_.on_trigger_line ? ", and no answer when asked" : "");
  }
  if (out.verdict == Verdict::Lost) {
    unanswered_ = 0;
    said_no_trigger_ = false;
  }
  return out;
}

bool CameraWatchdog::answered(bool answers) {
  if (!answers) {
    ++unanswered_;
    return false;
  }
  unanswered_ = 0;
  const bool say = !said_no_trigger_;
  said_no_trigger_ = true;
  return say;
}

}  // namespace pvcap
