#pragma once
// Whether a take matches its prompt, from the data just recorded: pressure
// present for Low/High (absent for No contact), High clearly above the same
// participant's Low for the same action and hand, the hand on its own half of
// the pad where that is defined, and no gap in the devices' streams.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "protocol/protocol.h"

namespace pvcap::protocol {

// One pressure frame of the take, summarised (codec/sensel_units.h: summarize_pressure).
struct ForcePoint {
  std::int64_t t_ns = 0;  // session clock
  double newtons = 0;
  double contact_mm2 = 0;
  double centroid_x_mm = 0;
};

struct TakeMeasures {
  std::size_t frames = 0;
  double mean_newtons = 0, peak_newtons = 0;  // total force over the take
  double mean_contact_mm2 = 0, peak_contact_mm2 = 0;
  std::optional<double> centroid_x_mm;  // force-weighted, when there was any force
  double max_pressure_gap_ms = 0;       // longest stretch without a pressure frame
};

TakeMeasures measure_take(const std::vector<ForcePoint>& points, std::int64_t from_ns, std::int64_t to_ns);

struct TakeCheck {
  bool ok = true;
  std::vector<std::string> problems;  // for the operator, each a sentence
  TakeMeasures measures;
};

struct TakeCheckInput {
  const Action* action = nullptr;
  Hand hand = Hand::Right;
  TakeMeasures measures;
  std::optional<double> low_mean_newtons;  // the same participant's Low take of this action and hand
  double max_camera_gap_ms = 0;            // longest silence of any camera during the take
  double pad_width_mm = 230;               // left hand on x < width/2, right hand on x >= width/2
  bool has_pressure = true;                // a rig without a Sensel checks only the cameras
  // The lighting commanded for the take and the lighting its images showed (codes in the rig's form,
  // "L-R"); either empty: not checked.
  std::string lighting_commanded, lighting_seen;
};

TakeCheck check_take(const TakeCheckInput& in, const TakeCheckConfig& cfg);
// "the images show lighting L--, not the LC- commanded (light C did not come on)": codes of one length.
std::string lighting_difference(const std::string& commanded, const std::string& seen);

}  // namespace pvcap::protocol
