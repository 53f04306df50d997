#pragma once
// One GigE Vision camera of the rig, through Aravis: connect, apply the rig
// config as GenICam features, check the link budget, stream, hand each frame to
// one consumer with its number and its losses, watch for loss and reconnect.
//
// Threads: open()/start()/stop() are called from the app's thread. Frames are
// assembled on Aravis' stream thread and taken by one consumer thread with
// next_frame() (see aravis_stream.h). A control thread per
// camera watches for a stalled stream or a lost control channel, reports it
// through the event handler within `stall_timeout()`, and tries to reconnect
// every second; it may block on network timeouts, which is why it is not the
// stream thread and not shared with other cameras. In software-trigger mode a
// trigger thread per camera sends one trigger per frame period.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "capture/camera_frame.h"
#include "capture/frame_sequencer.h"
#include "capture/genicam_features.h"
#include "core/bounded_queue.h"
#include "core/result.h"
#include "core/rig_config.h"

namespace pvcap {

// What the camera reports after configuration (it may round what was asked).
struct CameraSettings {
  std::string vendor, model, serial, device_id, address, firmware;
  std::string pixel_format;
  int x = 0, y = 0, width = 0, height = 0;
  double frame_rate = 0, exposure_us = 0, gain = 0;
  // The gain's unit (role_unit: "dB", or "GainRaw counts" where the camera has only its own counts)
  // and each frame's chunk gain's; the exposure is always in microseconds (converted from raw steps).
  std::string gain_unit, chunk_gain_unit;
  std::string trigger;
  unsigned packet_size = 0;
  std::size_t payload = 0;
  std::size_t buffer_count = 0;
  std::uint64_t timestamp_tick_hz = 0;
  // The feature each role was found under (role key -> name: capture/genicam_features.h), and the
  // version of the camera's node map.
  std::map<std::string, std::string> features;
  std::string node_map_version;
  // Every readable feature's value after configuration (the feature bag), at the first connection.
  std::map<std::string, std::string> feature_bag;
  // The chunk values each frame carries (role key -> the camera's name: chunk_exposure_time ->
  // ChunkExposureTime); empty when chunk mode is off.
  std::map<std::string, std::string> chunks;
  // On a link shared with other cameras: what paces it to its share ("GevSCPD 120 ticks: ..."), "" otherwise.
  std::string link_pacing;
};

struct CameraEvent {
  // NoTrigger: a camera on a trigger line sends nothing but answers: no trigger reaches it.
  // State: what the camera says of itself changed (its temperature by a degree, its PTP status).
  // PtpReading: its PTP state, once a second when the rig enables PTP (message: JSON, see
  // CameraPtpState); PtpOutOfLock: each second it is not locked (message: why).
  enum class Kind { Lost, Reconnected, NoTrigger, State, PtpReading, PtpOutOfLock };
  int camera = 0;
  Kind kind = Kind::Lost;
  HostNs at;
  std::string message;
};

// A camera's PTP state as its features say it (capture/genicam_features.h: ptp_status,
// ptp_servo_status, ptp_offset_from_master after ptp_data_set_latch).
struct CameraPtpState {
  std::string status;                     // as the camera names it: Slave, Master, Listening, ...
  std::optional<std::string> servo;       // PtpServoStatus, where it has one (Locked, Unknown)
  std::optional<std::int64_t> offset_ns;  // from its master, latched now, where it can say
  // Following a master (or being one) with its servo, where it says, locked.
  bool locked() const;
  std::string json() const;  // {"status", "servo", "offset_ns", "locked"}
  std::string describe() const;  // "Slave, servo Locked, offset -35 ns"
};

// The link and kernel limits a configuration must fit in.
struct LinkBudget {
  std::size_t payload_bytes = 0;  // one frame
  double frame_rate = 0;
  double link_mbps = 1000;
  int socket_buffer_bytes = 0;  // requested (0 = auto)
  long rmem_max = 0;            // net.core.rmem_max
  int link_cameras = 1;         // cameras sharing the link (each taken to need as much as this one)
  std::string link;             // its name, for the message
};
// Refuses a configuration the link or kernel cannot carry; the message says what to change.
Status preflight(const std::string& camera_label, const LinkBudget& budget);
// Reads net.core.rmem_max (0 when unreadable).
long read_rmem_max();
// A camera's share of a link `link_cameras` cameras share: the bytes per second it may send, and the
// gap to leave between its packets of `packet_bytes` beyond their own time on the wire, so that its
// bursts take no more of the link than its share (GigE cameras otherwise send a frame at line rate,
// and frames of several cameras at once overflow the port they share).
struct LinkPacing {
  double share_bytes_per_s = 0;
  double packet_delay_s = 0;
};
LinkPacing link_pacing(std::size_t packet_bytes, double link_mbps, int link_cameras);
// Buffers to allocate: the config's, or about half a second of frames (at least 8).
std::size_t buffer_count_for(const CameraConfig& config);

// The camera's clock read through its timestamp latch: `device` was the clock's value at
// some host instant in [host_lo, host_hi].
struct ClockProbe {
  std::uint32_t connection = 0;
  DeviceNs device;
  HostNs host_lo, host_hi;
};

class AravisStream;
class AravisFeatures;
struct NodeMapCheck;

class AravisCamera {
 public:
  using EventHandler = std::function<void(const CameraEvent&)>;

  AravisCamera(int index, CameraConfig config, EventHandler on_event);
  ~AravisCamera();
  AravisCamera(const AravisCamera&) = delete;
  AravisCamera& operator=(const AravisCamera&) = delete;

  // Connects, applies the configuration, preflights, allocates buffers. Errors name the
  // camera and the feature that failed.
  Status open();
  // The last open() failed on a camera that answered: its node map or the link cannot do what the
  // rig file asks (a rate out of reach, a pacing out of range, a pixel format it lacks). Unlike a
  // camera still booting, trying again will not help.
  bool refused() const { return refused_.load(); }
  // Waits until the stream may take frames (aravis_stream.h: accept_from_now). start() does it
  // itself; a rig calls it on every camera first, so the cameras then start together.
  void settle();
  // Starts acquisition and supervision.
  Status start();
  // Asks the control thread to stop acquisition; returns at once (stop() several cameras
  // in parallel by calling this on each first).
  void request_stop();
  // Stops acquisition and supervision and waits for it; the consumer then takes what is left.
  void stop();

  // The consumer's side, one thread: the next frame, numbered in the camera's own sequence
  // (frame_sequencer.h), waiting up to `timeout`; none when the wait ran out. A torn-down
  // connection's frames come before the next one's, then its last losses. Frames wait in the
  // stream's buffers (Aravis' own queue): a consumer that falls behind meets buffer underruns.
  std::optional<CameraFrame> next_frame(std::chrono::milliseconds timeout);
  // True once the camera is stopped and next_frame has taken every frame (the losses queue is
  // closed then).
  bool frames_done() const { return frames_done_.load(); }
  // The frames lost, with their reasons; closed once frames_done().
  BoundedQueue<FrameLoss>& losses() { return losses_; }
  // Timestamp-latch probes while streaming (four a second for a connection's first 5 s, while its
  // clock model converges; then one a second), from cameras that have a timestamp latch under any
  // of the names capture/genicam_features.h knows.
  BoundedQueue<ClockProbe>& clock_probes() { return probes_; }
  bool has_timestamp_latch() const;
  const CameraConfig& config() const { return config_; }
  // Switches the lights its output lines drive (config().lights; bit i: lights[i] on) and reads them
  // back (bit i: lights[i] reads on). From a control thread, never the capture thread: each is a few
  // GVCP round trips (aravis_camera_lights.cpp).
  Result<std::uint32_t> set_lights(std::uint32_t on);
  // Its PTP state now (a data set latched and read: a few GVCP round trips), from a control thread.
  Result<CameraPtpState> read_ptp();
  CameraSettings settings() const;
  StreamCounters counters() const;  // summed over every connection
  std::string label() const;        // "cam0 (serial PVSIM0 at 127.0.0.2)"
  // No frame for this long (free-run) means the camera is lost; the first frame after a
  // (re)start gets `first_frame_timeout()` (exposure, sensor start-up, a slow first packet).
  std::chrono::milliseconds stall_timeout() const;
  static constexpr std::chrono::milliseconds first_frame_timeout() { return std::chrono::milliseconds(3000); }

 private:
  Status connect_and_configure(std::uint32_t connection);
  Status apply_features();
  Status set_features(AravisFeatures& f);
  Status setting(Status s, const std::string& what) const;  // a failed setting, named with this camera
  Status set_trigger_and_rate(AravisFeatures& f);
  // Chunk mode on with every chunk pvcap reads that the camera has (none: left off); what it enabled
  // goes to chunk_features_. Not fatal: a camera whose chunks cannot be set records without them.
  void set_chunks(AravisFeatures& f);
  // Paces a camera on a shared link to its share (LinkPacing) through its bandwidth feature; refuses
  // one its feature cannot pace that far, naming the range. After the packet size is settled.
  Status set_link_pacing(AravisFeatures& f);
  // "cam0 (...): cannot reach 250 fps at 1280x720 BayerRG8 ...": `said` names what says so.
  Status unreachable_rate(const AravisFeatures& f, const std::string& said, double most) const;
  std::string link_pacing_;  // what set_link_pacing did, for CameraSettings
  std::map<CameraRole, std::string> chunk_features_;
  Status read_back(const AravisFeatures& f, const NodeMapCheck& check);
  bool features_said_ = false;  // what the camera cannot do is warned of once, not at every reconnection
  void teardown_connection(bool camera_reachable);
  void control_loop();
  // One attempt to connect again and restart acquisition (the watchdog found the camera lost).
  bool reconnect();
  void trigger_loop();  // TriggerMode::Software: one AcquisitionSoftwareTrigger per frame period
  enum class Probe { Taken, NotStreaming, Failed };
  // `at_start`: right after AcquisitionStart, before any frame (so the first frames are mapped by a
  // probe, not by their arrivals); otherwise only while frames flow (a vanished camera is not asked).
  // `width_ns`, when given, gets the taken probe's bracket (how well it pins the clock).
  Probe probe_clock(bool at_start = false, std::int64_t* width_ns = nullptr);
  // At acquisition start: probes until one's bracket is within 2 ms (at most five, each kept:
  // the clock model narrows to what all of them leave open). The first frames are mapped by these
  // alone, to half the tightest bracket: a GVCP answer held up 30 ms on a busy machine would put
  // them 15 ms off, out of their groups.
  void probe_clock_at_start();
  void probe_loop();  // its own thread: the probes while streaming
  // Read once a second from the probe thread, where the camera offers them: its temperature (a State
  // event at the first reading and at each change of a degree) and its PTP status (at each change).
  void watch_state();
  // The lights as last switched (set_lights), switched back on a reconnection.
  static constexpr std::uint32_t kLightsNeverSwitched = 0xFFFFFFFFu;
  std::atomic<std::uint32_t> lights_on_{kLightsNeverSwitched};
  Result<std::uint32_t> apply_lights(AravisFeatures& f, std::uint32_t on);
  std::optional<double> said_temperature_;
  std::string said_ptp_status_;
  bool ptp_out_of_lock_ = false;  // config().ptp: the last reading was not locked
  Status enable_ptp(AravisFeatures& f);  // config().ptp: at each configuration
  Result<CameraPtpState> read_ptp(AravisFeatures& f);
  void watch_ptp(AravisFeatures& f);  // config().ptp: a reading a second, each as an event
  void emit(CameraEvent::Kind kind, std::string message);

  const int index_;
  const CameraConfig config_;
  EventHandler on_event_;
  BoundedQueue<FrameLoss> losses_{4096};

  // The connection to the device (Aravis' camera, its stream, the control-lost signal): defined in
  // the .cpp, so no Aravis or GLib type reaches the code that records.
  struct Link;
  mutable std::mutex mu_;  // guards link_'s camera and stream, settings_, past_counters_
  std::unique_ptr<Link> link_;
  // What the consumer takes frames from, under a lock of its own (mu_ is held through a
  // reconnection's configuration): the connection's stream, and torn-down connections' streams
  // whose frames it has not all taken, oldest first.
  std::mutex feed_mu_;
  std::shared_ptr<AravisStream> feed_;
  std::deque<std::shared_ptr<AravisStream>> retired_;
  bool stopped_ = false;
  std::atomic<bool> frames_done_{false};
  CameraSettings settings_;
  StreamCounters past_counters_;
  std::string latch_command_, latch_value_;  // the latch's feature names, empty without one
  BoundedQueue<ClockProbe> probes_{256};

  std::atomic<bool> control_lost_{false};
  std::atomic<bool> running_{false};
  std::atomic<std::uint32_t> connection_{0};
  std::atomic<bool> refused_{false};
  HostNs started_at_;
  std::thread control_thread_;
  std::thread trigger_thread_;
  std::thread probe_thread_;
  std::mutex wake_mu_;
  std::condition_variable wake_;
};

}  // namespace pvcap
