#pragma once
// The automatic participant of a simulated rig (`pvcap session --auto`): a decorator of the
// protocol runner's environment that, as each take is scheduled, steers the simulated hand to
// perform it (the prompted hand, force level and repetitions; hovering for No contact) and takes it
// away when the take ends or is cancelled. Everything else goes to the environment it wraps.
#include <functional>
#include <memory>

#include "protocol/runner.h"
#include "sim/hand.h"

namespace pvcap {

class AutoParticipant : public protocol::RunnerEnv {
 public:
  using Steer = std::function<bool(const sim::HandCommand&)>;
  AutoParticipant(std::unique_ptr<protocol::RunnerEnv> inner, Steer steer);

  std::int64_t now_ns() override { return inner_->now_ns(); }
  bool commit(const ProtocolEventRecord& event) override { return inner_->commit(event); }
  bool commit_note(const std::string& text) override { return inner_->commit_note(text); }
  bool devices_live() override { return inner_->devices_live(); }
  double stream_silence_ms() override { return inner_->stream_silence_ms(); }
  bool has_pressure() override { return inner_->has_pressure(); }
  std::vector<protocol::ForcePoint> pressure(std::int64_t from_ns, std::int64_t to_ns) override {
    return inner_->pressure(from_ns, to_ns);
  }
  std::optional<std::string> set_lighting(const std::string& code) override { return inner_->set_lighting(code); }
  std::string lighting_seen(std::int64_t from_ns, std::int64_t to_ns) override {
    return inner_->lighting_seen(from_ns, to_ns);
  }
  std::string lighting_now() override { return inner_->lighting_now(); }
  void take_scheduled(const protocol::PlannedTake& take, std::int64_t start_ns, std::int64_t end_ns) override;
  void take_cancelled(std::int64_t at_ns) override;

 private:
  std::unique_ptr<protocol::RunnerEnv> inner_;
  Steer steer_;
};

// Where and how hard the automatic participant presses for a take (sensor mm, grams).
sim::HandCommand auto_hand_command(const protocol::PlannedTake& take, std::int64_t start_ns, double record_s);

}  // namespace pvcap
