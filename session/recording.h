#pragma once
// The running recording as a library object: what `pvcap session` runs, and what
// the protocol runner, the operator console and the pages attach to.
//
//   auto rec = Recording::open(rig, options, cancel);  // devices opened and checked; nothing on disk yet
//   rec->start();                                      // the session folder, then every device streaming
//   ... rec->status(), rec->post(event), rec->note(text) from any thread ...
//   rec->request_stop("protocol complete");            // or Ctrl-C, the duration, a failure
//   auto reason = rec->wait(interrupt, duration);      // returns once a stop is due
//   auto result = rec->finish(reason);                 // drain, re-map, close (the report is report/'s)
//
// One error channel: a failure that ends the session (storage, a device that
// cannot start) becomes the stop reason returned by wait(); warnings for the
// operator are logged and kept in status().warnings.
#include <atomic>
#include <chrono>
#include <deque>
#include <filesystem>
#include <functional>
#include <latch>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include "core/fault_injection.h"
#include "core/result.h"
#include "core/rig_config.h"
#include "lighting/light_meter.h"
#include "lighting/light_model.h"
#include "session/recording_status.h"
#include "session/sensel_pipeline.h"
#include "storage/index/records.h"

namespace pvcap {
namespace lighting {
class LightMonitor;
}
class AravisCamera;
class RecordingStore;
namespace sync {
class SessionTimeline;
}
}  // namespace pvcap

namespace pvcap::session {

struct CameraTally;
class PtpHostWatch;
class Preview;
class RigLock;
struct TimelineEnd;

struct RecordingOptions {
  std::filesystem::path root;  // the session folder is made under it
  double device_wait_s = 0;    // keep trying to open the devices this long (cameras still booting)
  // Where a Morph that comes back under another tty name is looked for by its serial.
  std::filesystem::path sensel_ports_dir = "/dev";
  std::optional<ParticipantRecord> participant;
  std::optional<ConditionsRecord> conditions;
  bool board_session = false;  // recording a calibration board session
  FaultPlan faults;            // a test's faults (core/fault_injection.h); empty on a real session
  // Called once every device has stopped streaming and every frame is handed to the store, before
  // the store is drained and closed (what served the devices may stop then).
  std::function<void()> on_devices_stopped;
  // The store the session is written into, made at start() (the rig, the session's wall-clock and
  // host-clock start); none: a SessionWriter making its folder under `root`. A test gives its own.
  std::function<Result<std::unique_ptr<RecordingStore>>(const RigConfig&, std::int64_t wall0_ns, std::int64_t host0_ns)>
      make_store;
};

// The sessions folder can take a session (made if missing, writable); an Error names it and why.
Status check_sessions_root(const std::filesystem::path& root);

struct RecordingResult {
  int exit_code = 0;  // 0 recorded, 1 failed (the message was logged)
  std::filesystem::path dir;
  double recorded_s = 0;           // from the devices' start to the stop
  std::vector<std::string> notes;  // for the end-of-session report: what went wrong in feeding the store
};

class Recording {
 public:
  static Result<std::unique_ptr<Recording>> open(const RigConfig& rig, const RecordingOptions& options,
                                                 const std::atomic<bool>& cancel);
  ~Recording();
  Recording(const Recording&) = delete;
  Recording& operator=(const Recording&) = delete;

  Status start();
  // Returns once a stop is due: `interrupt` set, `duration_s` reached, request_stop(), or a
  // failure. Logs progress every 2 s. The reason it returns is what finish() records.
  std::string wait(const std::atomic<bool>& interrupt, std::optional<double> duration_s);
  void request_stop(std::string reason);
  bool stop_requested() const { return stop_requested_.load(); }
  RecordingResult finish(const std::string& end_reason);

  // Any thread. Stamped on the capture clock (when 0) and committed to the store before it returns;
  // false when the store could not commit it within 2 s (the caller must not acknowledge it).
  bool post(ProtocolEventRecord event);
  bool note(std::string text);
  RecordingStatus status() const;

  const RigConfig& rig() const { return rig_; }
  std::filesystem::path dir() const;
  std::int64_t started_host_ns() const { return host0_; }
  // The operator's live views: a camera's latest small image, the latest pressure frame, and what
  // the pressure frames of a time span amounted to (for the take check).
  std::pair<cv::Mat, std::int64_t> preview(std::size_t camera) const;
  // The same preview's whole frame (for marking a point on it), with its arrival time; an empty
  // image when it arrived no later than `newer_than_ns`.
  std::pair<cv::Mat, std::int64_t> preview_full(std::size_t camera, std::int64_t newer_than_ns = -1) const;
  std::optional<PressureSnapshot> pressure_now() const;
  std::vector<PressurePoint> pressure_history(std::int64_t from_ns, std::int64_t to_ns) const;
  bool has_sensel() const { return bool(sensel_); }

  // The rig's lights (session/recording_lights.cpp, docs/lighting.md). Switches them to `code` and
  // commits the command with its read-back; the images' confirmation follows as its own event. The
  // code as commanded in the rig's form ("L-R"), or nullopt (why is logged). Any thread.
  std::optional<std::string> set_lighting(const std::string& code);
  // The lighting the images showed over [from, to), by the light check's model; "" without one.
  std::string lighting_seen(std::int64_t from_ns, std::int64_t to_ns) const;
  std::string lighting_now() const;  // as last commanded; "" on a rig without lights

 private:
  Recording();
  void warn(std::string message);
  void warn_of_losses();  // session/recording_warnings.cpp
  void log_progress(double elapsed_s);
  // The session's store: the options' make_store, or a SessionWriter under the root with the faults'
  // writer settings.
  Result<std::unique_ptr<RecordingStore>> make_store() const;
  void record_rig_calibration(RecordingStore& writer);
  // One worker per camera, started, and waited for until their buffers are ready (at most 3 s).
  void start_camera_workers(RecordingStore& writer);
  // Lights: each on alone for a moment at the start, learning what each adds to each camera's level,
  // then the session's lighting; a thread confirms every switch from the images.
  void run_light_check();
  Result<std::uint32_t> switch_lights(std::uint32_t mask, const std::string& why);
  std::uint32_t lighting_shown_now() const;  // the lights the last 150 ms of frames show
  void confirm_switches();
  void stop_light_thread();

  RigConfig rig_;
  RecordingOptions options_;
  std::unique_ptr<RigLock> rig_lock_;
  std::int64_t wall0_ = 0, host0_ = 0, rec_start_ = 0;
  std::vector<std::unique_ptr<AravisCamera>> cameras_;
  std::vector<std::unique_ptr<CameraTally>> tallies_;
  std::vector<std::unique_ptr<Preview>> previews_;
  std::unique_ptr<SenselPipeline> sensel_;
  std::unique_ptr<RecordingStore> writer_;
  std::atomic<RecordingStore*> events_writer_{nullptr};  // camera events reach the store once it exists
  std::vector<std::int64_t> device_ids_;
  std::int64_t sensel_id_ = 0;
  std::unique_ptr<sync::SessionTimeline> timeline_;
  std::unique_ptr<TimelineEnd> timeline_end_;
  std::unique_ptr<std::latch> workers_warmed_;  // the camera workers' buffers are written (start_camera_workers)
  std::int64_t pressure_max_offset_ns_ = 0;
  double sample_hz_ = 0;
  std::vector<std::thread> workers_;
  std::atomic<std::uint64_t> samples_{0};
  std::atomic<bool> stop_requested_{false};
  enum State { kOpened, kRecording, kStopping, kEnded };
  static constexpr const char* kStates[] = {"opened", "recording", "stopping", "ended"};
  std::atomic<int> state_{kOpened};  // a State; kStates names it
  std::string stop_reason_;
  std::optional<std::string> start_failure_;
  std::vector<bool> warned_encoder_, warned_spill_, warned_behind_, warned_foreign_;
  std::unique_ptr<lighting::LightMonitor> light_monitor_;                      // with lights: the cameras' levels
  std::vector<std::optional<std::array<lighting::Point, 4>>> pad_corners_px_;  // per camera, from its calibration
  struct PendingSwitch {
    std::int64_t command_ns;
    std::uint32_t from, to;
  };
  mutable std::mutex light_mu_;  // what follows
  std::optional<lighting::LightModel> light_model_;
  std::uint32_t lighting_mask_ = 0;
  bool lighting_commanded_ = false;
  std::vector<PendingSwitch> pending_switches_;
  std::unique_ptr<PtpHostWatch> ptp_watch_;  // rig file `ptp:`: the host's PTP time, every second
  std::atomic<bool> light_thread_running_{false};
  std::thread light_thread_;
  bool warned_sensel_behind_ = false, warned_index_ = false, warned_index_behind_ = false;

  mutable std::mutex mu_;  // what follows
  std::deque<std::string> warnings_;
  std::deque<double> recent_offsets_ms_;
  mutable std::vector<std::pair<std::int64_t, std::uint64_t>> rate_marks_;  // (host ns, received) per stream
  mutable std::vector<double> rates_;
};

}  // namespace pvcap::session
