#pragma once
// The cameras' light levels as they come (the light meter's, one per region of each good frame, on the
// session's clock), kept for the last minute, in channels (camera x kMeterRegions + region), and what they say of a switch of the lights: whether every camera
// that can see it shows the new lighting, how many of its frames after the command that took, and
// how long.
#include <cstdint>
#include <deque>
#include <mutex>
#include <string>
#include <vector>

#include "lighting/light_model.h"

namespace pvcap::lighting {

struct Level {
  std::int64_t t_ns = 0;  // the frame's instant, session clock
  double level = 0;
};

class LightMonitor {
 public:
  explicit LightMonitor(std::size_t channels);
  std::size_t channels() const { return per_camera_.size(); }
  // A camera's worker, once per good frame and region.
  void add(std::size_t channel, std::int64_t t_ns, double level);
  // A channel's levels with from_ns <= t < to_ns.
  std::vector<Level> levels(std::size_t channel, std::int64_t from_ns, std::int64_t to_ns) const;
  // Per channel, the median level over [from, to) (NaN without a frame there), and its spread (the
  // median absolute deviation, scaled to a standard deviation).
  std::vector<double> medians(std::int64_t from_ns, std::int64_t to_ns, std::vector<double>* spread = nullptr) const;

 private:
  struct Camera {
    mutable std::mutex mu;
    std::deque<Level> levels;
  };
  std::vector<Camera> per_camera_;
};

// A switch of the lights from `from` to `to`, commanded at `command_ns`, as the images show it up to
// `now_ns`: confirmed once every camera (`channels_per_camera` channels each) that can tell the two
// apart shows `to` in two frames running.
struct SwitchSeen {
  bool confirmed = false;
  bool visible = true;   // some camera can tell `from` from `to` (false: the model sees no difference)
  double delay_ms = 0;   // from the command to the first frame showing `to`, slowest camera
  int frames = 0;        // that camera's frames after the command that still showed `from`
  std::vector<int> channels_waiting;  // the first channel of each camera not yet showing it
};
SwitchSeen switch_seen(const LightModel& model, const LightMonitor& monitor, std::int64_t command_ns,
                       std::uint32_t from, std::uint32_t to, std::int64_t now_ns,
                       std::size_t channels_per_camera = 1);

}  // namespace pvcap::lighting
