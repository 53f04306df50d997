#pragma once
// The protocol runner attached to a running recording: events committed to its
// store, device liveness from its status, the take check's pressure from its
// Sensel pipeline, and (with --auto on a simulated rig) the automatic
// participant: the simulated hand performs each prompted take.
#include "protocol/runner.h"
#include "session/recording.h"

namespace pvcap::protocol {

class RecordingEnv : public RunnerEnv {
 public:
  // `auto_participant`: steer the simulated hand through each take (simulated rigs only).
  RecordingEnv(session::Recording& recording, bool auto_participant);

  std::int64_t now_ns() override;
  bool commit(const ProtocolEventRecord& event) override;
  bool commit_note(const std::string& text) override;
  bool devices_live() override;
  double stream_silence_ms() override;
  bool has_pressure() override;
  std::vector<ForcePoint> pressure(std::int64_t from_ns, std::int64_t to_ns) override;
  void take_scheduled(const PlannedTake& take, std::int64_t start_ns, std::int64_t end_ns) override;
  void take_cancelled(std::int64_t at_ns) override;

  static constexpr double kLiveWindowMs = 250;  // "delivered frames in the last 250 ms"

 private:
  session::Recording& recording_;
  bool auto_participant_;
};

// Where and how hard the automatic participant presses for a take (sensor mm, grams).
sim::HandCommand auto_hand_command(const PlannedTake& take, std::int64_t start_ns, double record_s);

}  // namespace pvcap::protocol
