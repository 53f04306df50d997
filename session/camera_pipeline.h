#pragma once
// One camera's part of a recording: a worker thread that takes the driver's
// frames (numbered by the driver, see capture/frame_sequencer.h) and losses,
// feeds the good frames to the timeline, and sends each to the store as the
// timeline decides: the kept frame of a sample to its video, every other frame
// to the index with its reason, every loss as a drop row. Never waits on the store.
#include <atomic>
#include <cstdint>
#include <latch>
#include <mutex>
#include <vector>

#include <opencv2/core.hpp>

#include "capture/aravis_camera.h"
#include "core/fault_injection.h"
#include "lighting/light_meter.h"
#include "lighting/light_monitor.h"
#include "storage/writer/recording_store.h"
#include "sync/session_timeline.h"

namespace pvcap::session {

// Per-camera counts the operator sees, filled by that camera's worker thread.
struct CameraTally {
  std::atomic<std::uint64_t> received{0}, good{0}, incomplete{0}, not_received{0}, encoder_behind{0}, lost_events{0};
  std::atomic<std::uint64_t> buffer_underrun{0};  // frames sent while the stream had no free buffer
  std::atomic<std::uint64_t> unidentified{0};     // buffers without their own id/timestamp, or duplicate ids
  std::atomic<std::uint64_t> foreign{0};          // another camera's frames its stream received (refused)
  std::atomic<std::uint64_t> arrivals_late{0};    // frames whose arrival is their take (CameraFrame::arrival_late)
  std::atomic<std::int64_t> last_good_host_ns{0};
};

// A small colour view of the latest frame, about once a second, for the operator's page.
class Preview {
 public:
  // `small` for the live thumbnails, `full` (the whole debayered frame) for marking points on it.
  void set(cv::Mat small, cv::Mat full, std::int64_t host_ns);
  // A copy of the latest view (empty before the first) and when it arrived (host clock).
  std::pair<cv::Mat, std::int64_t> get() const;
  // The whole frame only when it arrived after `newer_than_ns` (an empty image otherwise: a 1080p
  // copy is not made for a caller that has seen it).
  std::pair<cv::Mat, std::int64_t> get_full(std::int64_t newer_than_ns = -1) const;

 private:
  mutable std::mutex mu_;
  cv::Mat bgr_, full_;
  std::int64_t host_ns_ = 0;
};

// Tells the camera workers when the timeline has decided everything (after the last frame).
struct TimelineEnd {
  explicit TimelineEnd(std::size_t cameras);
  std::atomic<int> feeding{0};
  std::atomic<bool> flushed{false};
  // Set when the stop begins: from then on the timeline's flush decides every held frame, so the
  // workers no longer give one up as undecided (a camera slow to stop would otherwise lose frames
  // a sample already names).
  std::atomic<bool> stopping{false};

  // Each camera's worker: it has taken every frame that arrived before `host_ns` (INT64_MAX: it
  // takes no more).
  void caught_up(int camera, std::int64_t host_ns);
  // While the session stops: the instants before which no camera frame can still reach the
  // timeline. The worker furthest behind has taken everything that arrived before its mark, and a
  // frame arrives within `kArrivalNs` of its instant; frames a worker has yet to take (a backlog)
  // hold the mark back, so none of them comes too late for its instant.
  std::int64_t settled_before() const;
  static constexpr std::int64_t kArrivalNs = 300'000'000;

 private:
  std::vector<std::atomic<std::int64_t>> caught_up_;
};

struct CameraPipeline {
  AravisCamera& camera;
  int index;
  std::int64_t device_id;
  RecordingStore& writer;
  CameraTally& tally;
  sync::SessionTimeline& timeline;
  TimelineEnd& end;
  std::size_t encoder_queue;  // the store's queue_frames: how many images the encoder can hold
  Preview& preview;
  std::optional<Stall> stall;    // a test's fault (core/fault_injection.h): the worker sleeps once
  std::latch* warmed = nullptr;  // counted down once the worker's buffers are ready, before its first frame
  // With the rig's lights: each good frame's light level (lighting/light_meter.h) goes here, read off
  // the pad where its corners in the image are known.
  lighting::LightMonitor* light_monitor = nullptr;
  std::optional<std::array<lighting::Point, 4>> pad_corners_px;
};

// Runs until the camera's frame queue is closed and drained (after the camera stopped).
void run_camera_pipeline(const CameraPipeline& p);

}  // namespace pvcap::session
