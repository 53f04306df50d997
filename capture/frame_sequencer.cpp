#include "capture/frame_sequencer.h"

#include <algorithm>

namespace pvcap {

FrameSequencer::FrameSequencer(std::uint32_t connection, std::int64_t grace_ns)
    : connection_(connection),
      grace_ns_(grace_ns),
      gaps_(grace_ns, [this](const GapTracker::Gap& g) { report_gap(g); }) {
  settled_.reserve(64);  // the consumer's thread rarely allocates
}

void FrameSequencer::identify(CameraFrame& frame) {
  std::lock_guard lock(mu_);
  frame.sequence = 0;
  frame.lost_before = 0;
  if (frame.identity == FrameIdentity::Foreign) return;  // its id is of another camera's sequence
  if (frame.frame_id == 0) {
    // GigE Vision never sends id 0: the buffer got no leader packet, so it has no identity. The
    // frame it was is counted in a gap.
    frame.identity = FrameIdentity::NoFrameId;
    return;
  }
  const auto step = unwrap_.next(frame.frame_id);
  frame.sequence = step.sequence;
  frame.lost_before = step.missing;
  gaps_.missing(step.sequence - step.missing, step.missing, frame.host_ts.ns);
  if (step.out_of_order && !gaps_.arrived_late(step.sequence)) {
    // Not a frame we were missing. An incomplete buffer whose leader packet was lost still carries
    // the id and timestamp of the buffer's previous frame (seen with Aravis 0.8): the frame it
    // really was is already counted in a gap.
    frame.identity = frame.status == FrameStatus::Good ? FrameIdentity::Duplicate : FrameIdentity::StaleMetadata;
  } else {
    frame.identity = FrameIdentity::Own;
  }
}

void FrameSequencer::report_gap(const GapTracker::Gap& g) {
  // Frames Aravis had no free buffer for are gaps too; its counter says how many, not which: the
  // first ones of the gaps settled after it grew are charged to it.
  underrun_credit_ += underruns_now_ - std::min(underruns_now_, underruns_seen_);
  underruns_seen_ = std::max(underruns_seen_, underruns_now_);
  const std::uint64_t by_underrun = std::min(g.count, underrun_credit_);
  underrun_credit_ -= by_underrun;
  const HostNs noticed{g.noticed_ns};
  if (by_underrun > 0) settled_.push_back(FrameLoss{connection_, g.first, by_underrun, "buffer_underrun", noticed});
  if (g.count > by_underrun)
    settled_.push_back(FrameLoss{connection_, g.first + by_underrun, g.count - by_underrun, "not_received", noticed});
}

bool FrameSequencer::has_due(HostNs now) const {
  std::lock_guard lock(mu_);
  return !settled_.empty() || gaps_.oldest_noticed_ns().value_or(now.ns) <= now.ns - grace_ns_;
}

void FrameSequencer::settle(HostNs now, std::uint64_t underruns, std::vector<FrameLoss>& out, bool all) {
  std::lock_guard lock(mu_);
  underruns_now_ = underruns;
  gaps_.settle(now.ns, all);
  for (auto& loss : settled_) out.push_back(loss);
  settled_.clear();
}

}  // namespace pvcap
