#pragma once
// The Sensel's part of a recording: the device opened before anything is on
// disk, then a worker that moves its frames into the store, one row per frame,
// at full rate, and keeps a short history of what each frame amounted to (total
// force, contact, centre) for the protocol's take check and the operator's view.
#include <atomic>
#include <deque>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "capture/sensel_device.h"
#include "codec/sensel_units.h"
#include "core/fault_injection.h"
#include "core/result.h"
#include "core/rig_config.h"
#include "session/recording_status.h"
#include "storage/writer/recording_store.h"
#include "sync/session_timeline.h"

namespace pvcap::session {

struct PressurePoint {
  std::int64_t mapped_ns = 0;  // on the session clock
  std::uint64_t sequence = 0;
  sensel::PressureSummary summary;
};

struct SenselPipelineOptions {
  // Where a Morph that comes back under another tty name is looked for by its serial.
  std::filesystem::path ports_dir = "/dev";
  double wait_s = 2;  // keep trying to open it this long
  std::size_t queue_frames = sensel::SenselDevice::kQueueFrames;
  std::optional<Stall> stall;  // a test's fault (core/fault_injection.h): the worker sleeps once
};

class SenselPipeline {
 public:
  // Over USB by serial, or over a tty (a device path). Keeps trying for `options.wait_s`.
  static Result<std::unique_ptr<SenselPipeline>> open(const SenselRigConfig& cfg, const SenselPipelineOptions& options,
                                                      const std::atomic<bool>& cancel);
  ~SenselPipeline();

  DeviceRecord device_record() const;
  std::string connection() const;  // how the Morph is reached, for the operator and the devices table

  Status start(RecordingStore& writer, std::int64_t device_id, sync::SessionTimeline& timeline);
  void stop();

  std::uint64_t stored() const { return stored_.load(); }
  std::int64_t last_frame_host_ns() const { return last_host_ns_.load(); }
  std::uint64_t lost_frames() const { return device_->lost_frames(); }
  std::uint64_t queue_overflows() const { return device_->queue_overflows(); }
  std::uint64_t rejected_frames() const;
  bool lossy() const { return lost_frames() + queue_overflows() + rejected_frames() > 0; }

  // What the frames in [from_ns, to_ns) on the session clock amounted to (the last ~2 minutes are kept).
  std::vector<PressurePoint> history(std::int64_t from_ns, std::int64_t to_ns) const;
  PressureSnapshot latest() const;

 private:
  SenselPipeline() = default;
  void on_event(const sensel::SenselEvent& e);
  // Drops rows for the sequences [from, to) of `connection`: runs in `dropped` as queue_overflow,
  // the others as not_received.
  void record_losses(RecordingStore& writer, std::uint32_t connection, std::uint64_t from, std::uint64_t to,
                     const std::vector<std::uint64_t>& dropped, std::int64_t host_ns);
  void run();

  SenselRigConfig config_;
  std::optional<Stall> stall_;
  std::unique_ptr<sensel::SenselDevice> device_;
  std::atomic<RecordingStore*> writer_{nullptr};
  std::int64_t device_id_ = 0;
  sync::SessionTimeline* timeline_ = nullptr;
  std::thread worker_;
  std::atomic<std::uint64_t> stored_{0};
  std::optional<std::pair<std::uint32_t, std::uint64_t>> previous_;  // run(): the last frame's connection, sequence
  std::atomic<std::int64_t> last_host_ns_{0};
  mutable std::mutex history_mu_;
  std::deque<PressurePoint> history_;
  PressureSnapshot latest_;
};

}  // namespace pvcap::session
