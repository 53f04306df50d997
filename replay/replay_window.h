#pragma once
// `pvcap replay SESSION`: the session in a window (OpenCV highgui) - the picture of
// replay_composer.h for the sample shown, with a status line under it (playing or paused, speed,
// sample, time, the keys) - steered by the keys of replay_player.h. One sample's frames are
// decoded at a time: memory does not grow with the session's length. A slow machine shows fewer
// pictures, never a slower clock: playback follows the session's time.
#include <atomic>
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "core/result.h"

namespace pvcap::replay {

struct WindowOptions {
  double pressure_full_scale_kpa = 60;
  // Keys pressed in this order, one after each picture shown, before the keyboard is read (key
  // names as replay_player.h's key_from_name: demos, and tests under a headless display).
  std::vector<std::string> keys;
  bool from_raw = false;           // the views from the cameras' own videos, not their view videos
  std::filesystem::path snapshot;  // set: the last picture shown is written here (PNG) at the end
};

struct WindowSummary {
  std::size_t pictures = 0;  // shown
  std::size_t last_sample = 0;
};

Result<WindowSummary> run_replay_window(const std::filesystem::path& session, const WindowOptions& options,
                                        const std::atomic<bool>* stop = nullptr);

}  // namespace pvcap::replay
