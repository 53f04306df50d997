#pragma once
// `pvcap replay SESSION`: the session in a window, steered by keys (replay/replay_window.h).
// `pvcap replay SESSION --out FILE.mp4 [--take NAME] [--from S] [--to S] [--speed X]`: the session's
// four views with the pressure overlaid, the pressure image and the take's labels, rendered into a
// video without a display (replay/render_video.h), with progress and the time left.
// `pvcap replay SESSION --as-devices [--rate X] [--rig-out FILE]`: the rig file under which the
// simulated devices re-serve the session (sim/replay_rig.h), and the command that records it again.
#include <atomic>
#include <filesystem>

#include "replay/render_video.h"
#include "replay/replay_window.h"

namespace pvcap {

struct ReplayCommand {
  std::filesystem::path session;
  replay::RenderOptions options;
  bool as_devices = false;       // write the rig file that re-serves the session (sim/replay_rig.h)
  replay::WindowOptions window;  // neither --out nor --as-devices: the window (replay/replay_window.h)
  double rate = 1.0;
  std::filesystem::path rig_out;
};

int cmd_replay(const ReplayCommand& c, const std::atomic<bool>& stop);

}  // namespace pvcap
