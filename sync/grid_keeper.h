#pragma once
// Which frames of one stream go into the 15 Hz store: at most one frame per tick
// of a fixed grid anchored at the session start (so it never drifts): the first
// frame at or after half a source period before the tick. For a regular source
// that is the frame nearest the tick; a late (jittered) frame still serves its
// tick rather than leaving a hole, since each tick's window is a full grid period.
//
// This is the per-stream rule; the timeline work (grouper + subsampler over
// multi-camera groups on mapped time) will replace it for camera frames.
#include <cmath>
#include <cstdint>

namespace pvcap {

class GridKeeper {
 public:
  // `grid_hz` <= 0 keeps every frame. `source_hz` is the stream's nominal rate.
  GridKeeper(std::int64_t anchor_ns, double grid_hz, double source_hz)
      : anchor_ns_(anchor_ns),
        grid_ns_(grid_hz > 0 ? 1e9 / grid_hz : 0),
        half_period_ns_(source_hz > 0 ? 0.5e9 / source_hz : 0) {}

  bool keep(std::int64_t t_ns) {
    if (grid_ns_ <= 0) return true;
    const double rel = double(t_ns - anchor_ns_);
    const auto tick = std::int64_t(std::floor((rel + half_period_ns_) / grid_ns_));
    if (tick <= last_tick_) return false;
    last_tick_ = tick;
    return true;
  }

 private:
  std::int64_t anchor_ns_;
  double grid_ns_;
  double half_period_ns_;
  std::int64_t last_tick_ = -1;
};

}  // namespace pvcap
