#pragma once
// The sync self-check: each camera's time offset to the pressure stream estimated from the data
// alone, to catch what no clock model can see (a constant latency declared wrong, a timestamp
// taken at the wrong moment of the exposure).
//
// Around each isolated press, the image near the contact changes as the fingertip presses (it
// spreads, blanches, the hand moves down); the total pressure rises and falls with it. Whatever the
// relation between the two, it is the same on the way in and the way out. Shifted by the wrong
// offset, the rising edge's frames pair with too little pressure and the falling edge's with too
// much, and no one curve fits both. The estimate is the shift at which one smooth curve (a cubic,
// pooled over presses, each press's signals scaled to [0, 1], fitted to the frames on the presses'
// flanks) fits best, refined to a fraction of a millisecond by a parabola through the residual's
// minimum, once more without the presses that disagree with the rest; its uncertainty is the
// jackknife over presses (statistical only: presses recorded at
// the same phase of the frame grid share their bias).
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace pvcap::report {

struct TimedValue {
  std::int64_t t_ns = 0;  // session clock
  double value = 0;
};

// One press as both streams saw it.
struct PressSignals {
  std::vector<TimedValue> pressure;  // total pressure at full rate, in time order, covering the window
  std::vector<TimedValue> image;     // image change near the contact, one per camera frame in the window
};

struct OffsetEstimate {
  // How late the camera's timestamps are against what its pixels show, relative to the pressure
  // stream: positive when the camera's frames show an instant earlier than their time says.
  std::optional<double> offset_ms;
  std::optional<double> uncertainty_ms;  // one standard error (jackknife over presses)
  int presses_used = 0;
  int presses_rejected = 0;  // left out for disagreeing with the others (see consistent_presses)
  std::string verdict;       // "ok", or in words why there is no estimate
};

struct SelfCheckOptions {
  double search_ms = 60;  // offsets tried: [-search, +search]
  double step_ms = 0.5;
  int min_presses = 4;  // fewer: "too few presses to tell"
};

OffsetEstimate estimate_offset(const std::vector<PressSignals>& presses, const SelfCheckOptions& o = {});

}  // namespace pvcap::report
