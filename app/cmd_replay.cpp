// `pvcap replay SESSION`: the session in a window, steered by keys (replay/replay_window.h); with
// `--out FILE.mp4 [--take NAME] [--from S] [--to S] [--speed X]`, its views with the pressure overlaid,
// the pressure image and the take's labels rendered into a video without a display
// (replay/render_video.h); with `--as-devices [--rate X] [--rig-out FILE]`, the rig file under which the
// simulated devices re-serve it (sim/replay_rig.h) and the command that records it again.
#include "app/command.h"

#include "console/progress_line.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "replay/render_video.h"
#include "replay/replay_window.h"
#include "sim/replay_rig.h"

namespace pvcap {

namespace {
struct ReplayCommand {
  std::filesystem::path session;
  replay::RenderOptions options;
  bool as_devices = false;       // write the rig file that re-serves the session (sim/replay_rig.h)
  replay::WindowOptions window;  // neither --out nor --as-devices: the window (replay/replay_window.h)
  double rate = 1.0;
  std::filesystem::path rig_out;
};
}  // namespace

namespace {
// Whether there is a display to open a window on (DISPLAY, WAYLAND_DISPLAY or QT_QPA_PLATFORM set).
bool display_available() {
  for (const char* var : {"DISPLAY", "WAYLAND_DISPLAY", "QT_QPA_PLATFORM"})
    if (const char* v = std::getenv(var); v && *v) return true;
  return false;
}

// The devices start re-serving 0.2-0.3 s after the recording starts them (sim/session_replay.h):
// a session this much longer than the replay up to the cameras' last frame records every frame a
// sample can hold and stops before the cameras fall silent (sim::ReplayRig::record_seconds).
constexpr double kReplayStartS = 0.5;

int replay_as_devices(const ReplayCommand& c) {
  auto r = sim::write_replay_rig(c.session, c.rig_out, c.rate);
  if (!r) {
    spdlog::error("{}", r.error().message);
    return 1;
  }
  const auto& v = r.value();
  fmt::print(
      "replay rig: {}\n"
      "its simulated devices re-serve {:.1f} s of {} ({:.1f} s at rate {:g}) through the GigE Vision and "
      "Sensel protocols.\nrecord it again with:\n  pvcap session --rig {} --duration {:.1f}\n",
      v.rig_file.string(), v.session_seconds, c.session.string(), v.replay_seconds, c.rate, v.rig_file.string(),
      std::ceil(10 * (v.record_seconds + kReplayStartS)) / 10);
  return 0;
}
}  // namespace

namespace {

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
    w.from_raw = c.options.from_raw;
    if (!display_available()) {
      spdlog::error(
          "pvcap replay: no display to open the window on (DISPLAY is not set); render the session with "
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
  console::ProgressLine bar;
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
  fmt::print(
      "{}: {} frames, {:.1f} s of video showing {:.1f} s of the session, rendered in {:.1f} s ({:.2f} x real "
      "time)\n",
      c.options.out.string(), v.frames, v.video_seconds, v.session_seconds, v.seconds_taken,
      v.seconds_taken > 0 ? v.session_seconds / v.seconds_taken : 0);
  return 0;
}

}  // namespace

Registered add_replay_command(CLI::App& app, AppContext& ctx) {
  struct Args {
    ReplayCommand c;
    std::string take;
    double from = -1, to = -1;
  };
  auto a = std::make_shared<Args>();
  auto* r = app.add_subcommand("replay",
                               "render a recorded session into a video (the camera views with the pressure "
                               "overlaid through each calibration, the pressure image, the take, hand, force "
                               "and time), or re-serve it through the simulated devices (--as-devices); "
                               "without either, in a window (keys: space, arrows, [ ], p n, - +, q)");
  r->add_option("SESSION", a->c.session, "a session folder")->required()->check(CLI::ExistingDirectory);
  r->add_option("--out", a->c.options.out, "the video to write (.mp4, or .mkv)");
  r->add_flag("--as-devices", a->c.as_devices,
              "write a rig file whose simulated devices re-serve the session through the cameras' and the Sensel's "
              "own protocols; `pvcap session` on it records the session again");
  r->add_option("--rate", a->c.rate,
                "--as-devices: play this much faster (default 1: the original timing; the round trip is exact only "
                "at 1, as the device timestamps are scaled so the clocks keep their own rate)")
      ->check(CLI::Range(0.1, 10.0));
  r->add_option("--keys", a->c.window.keys,
                "the window: press these keys first (space, right, left, n, p, +, -, q, "
                "...; for demos and tests)")
      ->delimiter(',');
  r->add_option("--snapshot", a->c.window.snapshot, "the window: write its last picture here (PNG)");
  r->add_option("--rig-out", a->c.rig_out, "--as-devices: the rig file to write (default ./SESSION-replay.yaml)");
  r->add_option("--take", a->take, "only this take (its name, as `pvcap takes` lists it)");
  r->add_option("--from", a->from, "from this many seconds after the session's start");
  r->add_option("--to", a->to, "up to this many seconds after the session's start");
  r->add_option("--speed", a->c.options.speed, "playback speed (2: twice as fast; default 1)")
      ->check(CLI::PositiveNumber);
  r->add_flag("--from-raw", a->c.options.from_raw,
              "show the cameras from their lossless videos, not from the small view videos recorded beside them "
              "(slower; the same frames)");
  r->add_option("--pressure-max", a->c.options.pressure_full_scale_kpa,
                "pressure at the colour map's top, kPa "
                "(default 60)")
      ->check(CLI::PositiveNumber);
  return {r, [a, &ctx] {
            if (!a->take.empty()) a->c.options.take = a->take;
            if (a->from >= 0) a->c.options.from_s = a->from;
            if (a->to >= 0) a->c.options.to_s = a->to;
            return cmd_replay(a->c, ctx.stop);
          }};
}

}  // namespace pvcap
