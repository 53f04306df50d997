#include "app/auto_participant.h"

namespace pvcap {

AutoParticipant::AutoParticipant(std::unique_ptr<protocol::RunnerEnv> inner, Steer steer)
    : inner_(std::move(inner)), steer_(std::move(steer)) {}

sim::HandCommand auto_hand_command(const protocol::PlannedTake& take, std::int64_t start_ns, double record_s) {
  using protocol::Force;
  sim::HandCommand c;
  c.from_ns = start_ns;
  // Each hand on its own half of the pad (230 x 130 mm), one press per repetition.
  c.x_mm = take.hand == protocol::Hand::Left ? 69.0 : 161.0;
  c.y_mm = 65.0;
  c.period_s = record_s / take.action->repetitions;
  switch (take.action->force) {
    case Force::Low:
      c.peak_grams = 120;
      break;
    case Force::High:
      c.peak_grams = 450;
      break;
    case Force::Any:
      c.peak_grams = 250;
      break;
    case Force::NoContact:
      c.peak_grams = 0;
      break;
  }
  c.mode = take.action->force == Force::NoContact ? sim::HandCommand::Mode::Hover : sim::HandCommand::Mode::Press;
  return c;
}

void AutoParticipant::take_scheduled(const protocol::PlannedTake& take, std::int64_t start_ns, std::int64_t end_ns) {
  inner_->take_scheduled(take, start_ns, end_ns);
  steer_(auto_hand_command(take, start_ns, double(end_ns - start_ns) / 1e9));
  sim::HandCommand away;
  away.from_ns = end_ns;
  away.mode = sim::HandCommand::Mode::Away;
  steer_(away);
}

void AutoParticipant::take_cancelled(std::int64_t at_ns) {
  inner_->take_cancelled(at_ns);
  sim::HandCommand away;
  away.from_ns = at_ns;
  away.mode = sim::HandCommand::Mode::Away;
  steer_(away);
}

}  // namespace pvcap
