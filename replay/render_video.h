#pragma once
// `pvcap replay SESSION --out FILE.mp4`: the replay's pictures (replay_composer.h) rendered into a
// video file without a display, one picture per sample, timed by the session's clock (divided by
// the speed), optionally one take or a time range.
#include <atomic>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include "core/result.h"

namespace pvcap::replay {

struct RenderOptions {
  std::filesystem::path out;           // .mp4 (H.264); .mkv works too
  std::optional<std::string> take;     // only this take's samples
  std::optional<double> from_s, to_s;  // seconds from the session's start
  double speed = 1.0;                  // 2: the video plays twice as fast as the session went
  double pressure_full_scale_kpa = 60;
  // The views from the cameras' own (lossless) videos, not from their view videos
  // (storage/video/view_video.h): slower, for a session whose view videos are in doubt.
  bool from_raw = false;
};

struct RenderResult {
  std::size_t frames = 0;
  double video_seconds = 0;    // the rendered video's duration
  double session_seconds = 0;  // the stretch of the session it shows
  double seconds_taken = 0;    // wall time of the rendering
};

// `progress(done, total)` after each picture. The file is written under a temporary name and moved
// into place when complete: a rendering that fails or is interrupted leaves no half file.
// `stop` (Ctrl-C) ends it early, the same way.
Result<RenderResult> render_replay(const std::filesystem::path& session, const RenderOptions& options,
                                   const std::function<void(std::size_t, std::size_t)>& progress = nullptr,
                                   const std::atomic<bool>* stop = nullptr);

}  // namespace pvcap::replay
