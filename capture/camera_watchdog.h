#pragma once
// Whether a streaming camera is lost, decided from what its control thread sees: when the last frame
// came, whether frames still find no free buffer (a camera sending while pvcap holds every buffer is
// alive), whether Aravis says the control channel is gone, and, for a camera on a trigger line (which
// may rightly be silent), whether it answers when asked. Pure: no clock, no device, no thread; the
// camera driver feeds it (capture/aravis_camera.cpp) and every case is a unit test.
//
//   watchdog.started(now);                      // a stream starts (or restarts after a reconnect)
//   auto look = watchdog.look(now, last_frame, underruns, control_lost);
//   if (look.verdict == Verdict::Ask) watchdog.answered(ask_the_camera());  // once per Ask
//   if (look.verdict == Verdict::Lost) ...      // say look.why; reconnect
#include <chrono>
#include <cstdint>
#include <string>

#include "core/time.h"

namespace pvcap {

class CameraWatchdog {
 public:
  struct Config {
    std::chrono::milliseconds stall_timeout{500};         // silent this long: lost (free-running)
    std::chrono::milliseconds first_frame_timeout{3000};  // a (re)started stream's first frame may take this long
    bool on_trigger_line = false;  // hardware-triggered: silence alone is no loss, the camera is asked
    bool can_ask = false;          // it can be asked (an IPv4 address); otherwise only control_lost says lost
    std::chrono::milliseconds ask_every{250};
    int unanswered_limit = 3;  // asks without an answer before it is lost (~0.75 s)
  };
  enum class Verdict { Fine, Ask, Lost };
  struct Look {
    Verdict verdict = Verdict::Fine;
    std::int64_t silent_ms = 0;  // since the last frame (or underrun, or the stream's start)
    std::string why;             // Lost: in words
  };

  explicit CameraWatchdog(Config config) : config_(config) {}

  // A stream starts: its first frame gets first_frame_timeout, its underruns count from zero.
  void started(HostNs at);
  // One look at the camera now. `last_frame`: the last frame's arrival (0: none yet); `underruns`:
  // the stream's count so far; `control_lost`: Aravis' control-lost signal came.
  Look look(HostNs now, HostNs last_frame, std::uint64_t underruns, bool control_lost);
  // The camera's answer to the Ask look() gave. True when "no trigger reaches it" is to be said: it
  // answers while silent (said once per silence).
  bool answered(bool answers);

 private:
  Config config_;
  HostNs started_at_{0};
  std::uint64_t underruns_seen_ = 0;
  HostNs underrun_at_{0};
  HostNs last_ask_{0};
  int unanswered_ = 0;
  bool said_no_trigger_ = false;
};

}  // namespace pvcap
