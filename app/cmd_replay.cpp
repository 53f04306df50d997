#include "app/cmd_replay.h"

#include <unistd.h>

#include <chrono>
#include <cstdio>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace pvcap {

int cmd_replay(const ReplayCommand& c, const std::atomic<bool>& stop) {
  if (c.options.out.empty()) {
    spdlog::error("pvcap replay needs --out FILE.mp4 (the replay window is not built yet)");
    return 2;
  }
  const auto started = std::chrono::steady_clock::now();
  const bool terminal = isatty(STDERR_FILENO) == 1;
  int last_decile = -1;
  // A progress bar rewritten in place on a terminal; a line per tenth in a log.
  auto progress = [&](std::size_t done, std::size_t total) {
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    const double rate = s > 0 ? double(done) / s : 0;
    const double left = rate > 0 ? double(total - done) / rate : 0;
    const int filled = total ? int(30 * done / total) : 30;
    const std::string line = fmt::format("[{}{}] {}/{} samples, {:.1f}/s, {:.0f} s left", std::string(filled, '#'),
                                         std::string(30 - filled, ' '), done, total, rate, left);
    if (terminal) {
      fmt::print(stderr, "\r{}\x1b[K{}", line, done >= total ? "\n" : "");
      std::fflush(stderr);
    } else if (const int decile = total ? int(10 * done / total) : 10; decile != last_decile) {
      last_decile = decile;
      spdlog::info("{}", line);
    }
  };
  auto r = replay::render_replay(c.session, c.options, progress, &stop);
  if (!r) {
    if (terminal) fmt::print(stderr, "\n");
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
