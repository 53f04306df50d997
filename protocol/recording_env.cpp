#include "protocol/recording_env.h"

#include <algorithm>

#include "core/time.h"

namespace pvcap::protocol {

RecordingEnv::RecordingEnv(session::Recording& recording, bool auto_participant)
    : recording_(recording), auto_participant_(auto_participant) {}

std::int64_t RecordingEnv::now_ns() { return host_now().ns; }

bool RecordingEnv::commit(const ProtocolEventRecord& event) { return recording_.post(event); }

bool RecordingEnv::commit_note(const std::string& text) { return recording_.note(text); }

bool RecordingEnv::devices_live() { return recording_.status().all_live(kLiveWindowMs); }

double RecordingEnv::stream_silence_ms() {
  double worst = 0;
  for (const auto& s : recording_.status().streams)
    worst = std::max(worst, s.since_last_frame_ms < 0 ? 1e9 : s.since_last_frame_ms);
  return worst;
}

bool RecordingEnv::has_pressure() { return recording_.has_sensel(); }

std::vector<ForcePoint> RecordingEnv::pressure(std::int64_t from_ns, std::int64_t to_ns) {
  std::vector<ForcePoint> out;
  for (const auto& p : recording_.pressure_history(from_ns, to_ns))
    out.push_back({p.mapped_ns, p.summary.total_newtons, p.summary.contact_area_mm2, p.summary.centroid_x_mm});
  return out;
}

sim::HandCommand auto_hand_command(const PlannedTake& take, std::int64_t start_ns, double record_s) {
  sim::HandCommand c;
  c.from_ns = start_ns;
  // Each hand on its own half of the pad (230 x 130 mm), one press per repetition.
  c.x_mm = take.hand == Hand::Left ? 69.0 : 161.0;
  c.y_mm = 65.0;
  c.period_s = record_s / take.action->repetitions;
  switch (take.action->force) {
    case Force::Low: c.peak_grams = 120; break;
    case Force::High: c.peak_grams = 450; break;
    case Force::Any: c.peak_grams = 250; break;
    case Force::NoContact: c.peak_grams = 0; break;
  }
  c.mode = take.action->force == Force::NoContact ? sim::HandCommand::Mode::Hover : sim::HandCommand::Mode::Press;
  return c;
}

void RecordingEnv::take_scheduled(const PlannedTake& take, std::int64_t start_ns, std::int64_t end_ns) {
  if (!auto_participant_) return;
  recording_.steer_sim_hand(auto_hand_command(take, start_ns, double(end_ns - start_ns) / 1e9));
  sim::HandCommand away;
  away.from_ns = end_ns;
  away.mode = sim::HandCommand::Mode::Away;
  recording_.steer_sim_hand(away);
}

void RecordingEnv::take_cancelled(std::int64_t at_ns) {
  if (!auto_participant_) return;
  sim::HandCommand away;
  away.from_ns = at_ns;
  away.mode = sim::HandCommand::Mode::Away;
  recording_.steer_sim_hand(away);
}

}  // namespace pvcap::protocol
