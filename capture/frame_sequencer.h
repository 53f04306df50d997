#pragma once
// Gives each frame of one camera connection its place in the camera's own
// numbering, as the Sensel driver does for its frames: the 16-bit GigE Vision
// frame id unwrapped into a sequence, the ids skipped before it, and whether the
// buffer is the frame it claims to be. Frames that never reach the consumer are
// reported as losses with their true reason:
//  - buffer_underrun: sent while Aravis had no free buffer (its underrun counter grew: the
//    consumer held every buffer, or had not taken the frames waiting in them);
//  - not_received: lost on the link, or never sent.
// A gap is held open for a grace period before it is reported, because GigE
// Vision delivers a timed-out incomplete frame after its successor.
//
// Threads: identify() runs on the consumer's thread; settle() also on the camera's
// control thread. A mutex held for microseconds guards the state.
#include <cstdint>
#include <mutex>
#include <vector>

#include "capture/camera_frame.h"
#include "core/gap_tracker.h"
#include "core/sequence_unwrap.h"

namespace pvcap {

struct FrameLoss {
  std::uint32_t connection = 0;
  std::uint64_t first = 0;  // sequence of the first frame lost
  std::uint64_t count = 0;
  const char* reason = "";  // buffer_underrun or not_received
  HostNs noticed;
};

class FrameSequencer {
 public:
  explicit FrameSequencer(std::uint32_t connection, std::int64_t grace_ns = 1'000'000'000);

  // Sets the frame's sequence, lost_before and identity from its frame id.
  void identify(CameraFrame& frame);
  // Moves the losses that are settled (gaps older than the grace; every gap when `all`) to
  // `out`. `underruns` is the stream's underrun counter now: gaps it grew during are frames
  // Aravis had no buffer for.
  void settle(HostNs now, std::uint64_t underruns, std::vector<FrameLoss>& out, bool all = false);
  // True when settle() has something to report at `now` (cheap; lets a caller skip reading
  // the underrun counter).
  bool has_due(HostNs now) const;

 private:
  void report_gap(const GapTracker::Gap& g);

  const std::uint32_t connection_;
  const std::int64_t grace_ns_;
  mutable std::mutex mu_;
  SequenceUnwrapper unwrap_{16, /*zero_is_skipped=*/true};
  GapTracker gaps_;
  std::vector<FrameLoss> settled_;
  std::uint64_t underruns_seen_ = 0, underrun_credit_ = 0, underruns_now_ = 0;
};

}  // namespace pvcap
