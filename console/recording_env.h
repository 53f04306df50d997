#pragma once
// The protocol runner attached to a running recording: events committed to its store, device
// liveness from its status, the take check's pressure from its Sensel pipeline. An automatic
// participant (a simulated rig's hand) decorates this environment from outside (app/).
#include "protocol/runner.h"
#include "session/recording.h"

namespace pvcap::console {

class RecordingEnv : public protocol::RunnerEnv {
 public:
  explicit RecordingEnv(session::Recording& recording);

  std::int64_t now_ns() override;
  bool commit(const ProtocolEventRecord& event) override;
  bool commit_note(const std::string& text) override;
  bool devices_live() override;
  double stream_silence_ms() override;
  bool has_pressure() override;
  std::vector<protocol::ForcePoint> pressure(std::int64_t from_ns, std::int64_t to_ns) override;

  static constexpr double kLiveWindowMs = 250;  // "delivered frames in the last 250 ms"

 private:
  session::Recording& recording_;
};

}  // namespace pvcap::console
