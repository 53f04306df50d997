#include "console/recording_env.h"

#include <algorithm>

#include "core/time.h"

namespace pvcap::console {

RecordingEnv::RecordingEnv(session::Recording& recording) : recording_(recording) {}

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

std::vector<protocol::ForcePoint> RecordingEnv::pressure(std::int64_t from_ns, std::int64_t to_ns) {
  std::vector<protocol::ForcePoint> out;
  for (const auto& p : recording_.pressure_history(from_ns, to_ns))
    out.push_back({p.mapped_ns, p.summary.total_newtons, p.summary.contact_area_mm2, p.summary.centroid_x_mm});
  return out;
}

}  // namespace pvcap::console
