#include "app/cmd_replay.h"

#include "app/progress_line.h"

#include <chrono>
#include <cmath>
#include <cstdio>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "replay/as_devices.h"

namespace pvcap {

namespace {
// The devices start re-serving 0.2-0.3 s after the recording starts them (sim/session_replay.h):
// a session this much longer than the replay records all of it and stops before they fall silent.
constexpr double kReplayStartS = 0.5;

int replay_as_devices(const ReplayCommand& c) {
  auto r = replay::write_replay_rig(c.session, c.rig_out, c.rate);
  if (!r) {
    spdlog::error("{}", r.error().message);
    return 1;
  }
  const auto& v = r.value();
  fmt::print("replay rig: {}\n"
             "its simulated devices re-serve {:.1f} s of {} ({:.1f} s at rate {:g}) through the GigE Vision and "
             "Sensel protocols.\nrecord it again with:\n  pvcap session --rig {} --duration {:.1f}\n",
             v.rig_file.string(), v.session_seconds, c.session.string(), v.replay_seconds, c.rate,
             v.rig_file.string(), std::ceil(10 * (v.replay_seconds + kReplayStartS)) / 10);
  return 0;
}
}  // namespace

int cmd_replay(const ReplayCommand& c, const std::atomic<bool>& stop) {
  if (c.as_devices) {
    if (!c.options.out.empty()) {
      spdlog::error("pvcap replay: --as-devices and --out are two different replays; give one");
      return 2;
    }
    return replay_as_devices(c);
  }
  if (c.options.out.empty()) {
    replay::WindowOptions w = c.window;
    w.pressure_full_scale_kpa = c.options.pressure_full_scale_kpa;
    if (!replay::display_available()) {
      spdlog::error("pvcap replay: no display to open the window on (DISPLAY is not set); render the session with "
                    "--out FILE.mp4, or re-serve it with --as-devices");
      return 2;
    }
    auto shown = replay::run_replay_window(c.session, w, &stop);
    if (!shown) {
      spdlog::error("{}", shown.error().message);
      return 1;
    }
    fmt::print("replay window closed: {} pictures shown, the last of sample {}\n", shown.value().pictures,
               shown.value().last_sample);
    return 0;
  }
  const auto started = std::chrono::steady_clock::now();
  ProgressLine bar;
  auto progress = [&](std::size_t done, std::size_t total) {
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    const double rate = s > 0 ? double(done) / s : 0;
    const double left = rate > 0 ? double(total - done) / rate : 0;
    const int filled = total ? int(30 * done / total) : 30;
    bar.show(fmt::format("[{}{}] {}/{} samples, {:.1f}/s, {:.0f} s left", std::string(filled, '#'),
                         std::string(30 - filled, ' '), done, total, rate, left),
             done, total);
  };
  auto r = replay::render_replay(c.session, c.options, progress, &stop);
  if (!r) {
    bar.abandon();
    spdlog::error("{}", r.error().message);
    return 1;
  }
  const auto& v = r.value();
  fmt::print("{}: {} frames, {:.1f} s of video showing {:.1f} s of the session, rendered in {:.1f} s ({:.2f} x real "
             "time)\n",
             c.options.out.string(), v.frames, v.video_seconds, v.session_seconds, v.seconds_taken,
             v.seconds_taken > 0 ? v.session_seconds / v.seconds_taken : 0);
  return 0;
}

}  // namespace pvcap
