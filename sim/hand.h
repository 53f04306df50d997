#pragma once
// The simulated hand shared by the simulated cameras and the Sensel emulator: at
// every true instant, where the fingertip is and how hard it presses, so the
// images and the pressure of a simulated session agree.
//
// By default it presses periodically at the rig file's `sim.sensel` spot. A
// recording that runs the protocol with `--auto` steers it instead: one command
// per prompted take, sent to the simulator process as a text line (see
// HandCommand::parse), each applying from a true instant on.
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "core/rig_config.h"
#include "sim/sim_config.h"

namespace pvcap::sim {

struct HandCommand {
  enum class Mode { Away, Hover, Press };
  std::int64_t from_ns = 0;  // true time (CLOCK_MONOTONIC) the command applies from
  Mode mode = Mode::Press;
  double x_mm = 115, y_mm = 65;  // where the fingertip is (sensor mm)
  double peak_grams = 300;       // press strength on its centre cell
  double period_s = 2.0;         // one press and release per period

  // "hand <from_ns> <away|hover|press> <x_mm> <y_mm> <peak_grams> <period_s>"
  std::string format() const;
  static std::optional<HandCommand> parse(const std::string& line);
};

// Where the hand is at one instant.
struct HandPose {
  bool visible = false;  // in the cameras' view: hovering, or pressing
  double x_mm = 0, y_mm = 0;
  double force = 0;       // press strength in [0, 1]
  double peak_grams = 0;  // grams on the centre cell at force 1
};

class Hand {
 public:
  explicit Hand(const SimSenselConfig& defaults);
  void set(const HandCommand& c);
  HandPose pose_at(std::int64_t true_ns) const;

 private:
  mutable std::mutex mu_;
  // By from_ns: each in force from its instant until the next one's (the first always applies).
  std::vector<HandCommand> commands_;
};

}  // namespace pvcap::sim
