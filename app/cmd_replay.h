#pragma once
// `pvcap replay SESSION --out FILE.mp4 [--take NAME] [--from S] [--to S] [--speed X]`: the session's
// four views with the pressure overlaid, the pressure image and the take's labels, rendered into a
// video without a display (replay/render_video.h), with progress and the time left.
#include <atomic>
#include <filesystem>

#include "replay/render_video.h"

namespace pvcap {

struct ReplayCommand {
  std::filesystem::path session;
  replay::RenderOptions options;
};

int cmd_replay(const ReplayCommand& c, const std::atomic<bool>& stop);

}  // namespace pvcap
