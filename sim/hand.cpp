#include "sim/hand.h"

#include <sstream>

#include <fmt/format.h>

#include "sim/fingertip.h"

namespace pvcap::sim {

namespace {
const char* mode_name(HandCommand::Mode m) {
  switch (m) {
    case HandCommand::Mode::Away:
      return "away";
    case HandCommand::Mode::Hover:
      return "hover";
    case HandCommand::Mode::Press:
      return "press";
  }
  return "away";
}
}  // namespace

std::string HandCommand::format() const {
  return fmt::format("hand {} {} {:.3f} {:.3f} {:.1f} {:.3f}", from_ns, mode_name(mode), x_mm, y_mm, peak_grams,
                     period_s);
}

std::optional<HandCommand> HandCommand::parse(const std::string& line) {
  std::istringstream in(line);
  std::string word, mode;
  HandCommand c;
  if (!(in >> word) || word != "hand") return std::nullopt;
  if (!(in >> c.from_ns >> mode >> c.x_mm >> c.y_mm >> c.peak_grams >> c.period_s)) return std::nullopt;
  if (mode == "away")
    c.mode = Mode::Away;
  else if (mode == "hover")
    c.mode = Mode::Hover;
  else if (mode == "press")
    c.mode = Mode::Press;
  else
    return std::nullopt;
  if (!(c.period_s > 0.05 && c.period_s < 600) || !(c.peak_grams >= 0 && c.peak_grams < 1e5)) return std::nullopt;
  return c;
}

Hand::Hand(const SimSenselConfig& d) {
  commands_.push_back(HandCommand{0, HandCommand::Mode::Press, d.press_x_mm, d.press_y_mm, d.peak_grams, d.period_s});
}

void Hand::set(const HandCommand& c) {
  std::lock_guard lock(mu_);
  // A command replaces those it comes before (a take cancelled before it began).
  while (commands_.size() > 1 && commands_.back().from_ns >= c.from_ns) commands_.pop_back();
  commands_.push_back(c);
  if (commands_.size() > 64) commands_.erase(commands_.begin());  // the past is not looked at again
}

HandPose Hand::pose_at(std::int64_t true_ns) const {
  HandCommand c;
  {
    std::lock_guard lock(mu_);
    c = commands_.front();
    for (const auto& k : commands_)
      if (k.from_ns <= true_ns) c = k;
  }
  HandPose p;
  if (c.mode == HandCommand::Mode::Away) return p;
  p.x_mm = c.x_mm;
  p.y_mm = c.y_mm;
  p.peak_grams = c.peak_grams;
  // The default hand presses on an absolute phase (from_ns 0); a commanded one starts its first
  // press at its command's instant.
  if (c.mode == HandCommand::Mode::Press) p.force = fingertip_force(true_ns - c.from_ns, c.period_s);
  // Between presses the fingertip is lifted out of the cameras' way; hovering, it stays in view.
  p.visible = c.mode == HandCommand::Mode::Hover || p.force > 0;
  return p;
}

}  // namespace pvcap::sim
