#pragma once
// What a running recording reports of itself: plain snapshots, read by the console, the pages and
// the tests without the devices or the store behind them.
#include <cstdint>
#include <string>
#include <vector>

#include "codec/sensel_units.h"

namespace pvcap::session {

struct StreamStatus {
  std::string name, kind;  // kind: camera | sensel
  std::uint64_t received = 0, good = 0, in_video = 0, incomplete = 0, not_received = 0, encoder_behind = 0,
                connection_losses = 0;
  std::uint64_t queue_overflow = 0;   // received by the driver and dropped, its queue full (pvcap too slow)
  std::uint64_t buffer_underrun = 0;  // sent while the camera's stream had no free buffer (pvcap too slow)
  std::size_t encoder_backlog = 0;    // kept frames waiting for the encoder (memory and spill)
  std::size_t spill_backlog = 0;      // of which on disk
  std::uint64_t spilled = 0;          // frames that went through the spill so far
  double rate_hz = 0;                 // over the last status interval
  double since_last_frame_ms = -1;    // since its last good frame arrived; -1: none yet
};

struct RecordingStatus {
  std::string state;  // opened | recording | stopping | ended
  std::string session_dir;
  double elapsed_s = 0;
  std::vector<StreamStatus> streams;  // the cameras in rig order, then the Sensel
  std::uint64_t samples = 0;
  double pressure_offset_mean_ms = 0, pressure_offset_max_ms = 0;  // |sample - nearest pressure frame|, recent
  std::int64_t free_disk_bytes = -1;
  std::vector<std::string> warnings;  // the latest operator warnings, oldest first
  // True while every stream delivered a good frame within `window_ms`.
  bool all_live(double window_ms) const {
    if (streams.empty()) return false;
    for (const auto& s : streams)
      if (s.since_last_frame_ms < 0 || s.since_last_frame_ms > window_ms) return false;
    return true;
  }
};

// The latest pressure frame, for the live heat map.
struct PressureSnapshot {
  sensel::Grid grid;
  std::vector<std::uint16_t> counts;
  std::int64_t mapped_ns = 0;
};

}  // namespace pvcap::session
