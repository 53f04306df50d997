#pragma once
// A Sensel Morph over any Transport: the open sequence (magic, soft reset, the
// information registers), configuration from the rig, and a streaming thread
// that polls frames (sync mode) and stamps each with pvcap's CLOCK_MONOTONIC
// midpoint of request and answer.
//
// Threads: open()/configure()/start()/stop() from the app's thread; frames are
// produced on the device's own thread into a bounded queue (never waits on the
// consumer). A stall (no answer in 500 ms), garbage (a bad checksum, an
// undecodable frame) and an unplug are reported through the event handler and
// survived: garbage is skipped, an unplugged device is reopened every second.
#include <atomic>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "codec/sensel_frame.h"
#include "codec/sensel_protocol.h"
#include "capture/sensel_transport.h"
#include "core/bounded_queue.h"
#include "core/result.h"
#include "core/sequence_unwrap.h"
#include "core/time.h"

namespace pvcap::sensel {

struct SenselConfig {
  int scan_detail = 1;  // 0 high (93x53, ~50 Hz), 1 medium (47x27, ~125 Hz)
  std::uint8_t content = kPressure | kLabels | kContacts | kAccel;
  bool dynamic_baseline = false;  // off: static loads must not decay on a capture rig
  int frame_rate_cap = 0;         // Hz written to SCAN_FRAME_RATE; 0 leaves the device's
};

struct SenselInfo {
  std::string serial;    // register 0x0F (13 characters)
  std::string firmware;  // "0.16.78"
  Grid grid;
};

// One frame as the pipeline sees it: the raw counts on the native grid with its grid,
// and all three time bases' inputs.
struct PressureSample {
  HostNs host_ts;                 // midpoint of request and answer
  std::int64_t host_wait_ns = 0;  // answer time minus request time (the stamp's uncertainty)
  HostNs first_byte_ts;           // when the answer's first bytes arrived (its earliest sign, for clock models)
  DeviceNs device_ts;             // device µs timestamp, unwrapped past 2^32, in ns
  std::uint32_t connection = 0;   // 0, then one more after each reconnect (the counter restarts with it)
  std::uint64_t sequence = 0;     // rolling counter, unwrapped (within the connection)
  std::uint64_t lost_before = 0;  // frames the counter says were skipped before this one
  // Frames of this connection received since the previous sample handed over, and dropped for
  // want of room in the driver's queue (their sequences): lost with that reason.
  std::vector<std::uint64_t> dropped_before;
  Grid grid;
  Frame frame;                        // contacts, accelerometer, pressure counts, labels
  std::vector<std::uint8_t> payload;  // the frame exactly as the device sent it (checksum verified)
};

struct SenselEvent {
  // WrongDevice: after an unplug, a Morph with another serial (or grid) answered where the
  // session's was; it is not recorded, and the driver keeps looking for the session's own.
  enum class Kind { Stall, Garbage, Unplugged, Reconnected, WrongDevice } kind;
  HostNs at;
  std::string message;
  std::uint32_t connection = 0;        // Reconnected: the new connection's number
  std::int64_t away_ns = 0;            // Reconnected: how long the device was gone
  std::uint64_t missed = 0;            // Reconnected: frames it would have sent meanwhile, at its rate before
  std::vector<std::uint64_t> dropped;  // Reconnected: the previous connection's last frames the queue had no room for
};

class SenselDevice {
 public:
  // Opens the link to the Morph. `session_serial` is empty for the first open; on a reconnect it
  // names the Morph the session records, so a factory can look for it where it now is.
  using TransportFactory = std::function<Result<std::unique_ptr<Transport>>(const std::string& session_serial)>;
  using EventHandler = std::function<void(const SenselEvent&)>;

  // About 4 s of frames at medium detail.
  static constexpr std::size_t kQueueFrames = 512;

  // Opens through `factory` (called again to reconnect) and runs the open sequence. `queue_frames`:
  // the frame queue's size (a test shrinks it to meet a queue that overflows).
  static Result<std::unique_ptr<SenselDevice>> open(TransportFactory factory, EventHandler on_event = nullptr,
                                                    std::size_t queue_frames = kQueueFrames);
  // Reads serial, firmware and grid without resetting or configuring anything (for listings).
  static Result<SenselInfo> probe(std::unique_ptr<Transport> transport);
  ~SenselDevice();

  Status configure(const SenselConfig& config);
  // Writes a variable-size register (e.g. LED_BRIGHTNESS, 0x80) with WVS: header, then chunks of
  // at most 512 bytes, each acknowledged. Not while streaming (the channel is the stream's).
  Status write_variable(std::uint8_t reg, std::span<const std::uint8_t> data);
  Status start();
  void stop();  // stops scanning; closes the queue after the last frame

  const SenselInfo& info() const { return info_; }
  BoundedQueue<PressureSample>& samples() { return queue_; }
  std::uint64_t frames() const { return frames_.load(); }
  std::uint64_t lost_frames() const { return lost_.load(); }
  std::uint64_t queue_overflows() const { return overflows_.load(); }
  std::map<std::string, std::uint64_t> rejected() const;  // reason -> count

 private:
  SenselDevice(TransportFactory factory, EventHandler on_event, std::size_t queue_frames);
  Status open_sequence(bool soft_reset = true);
  // Reads the settings back from the Morph: a mismatch is an error naming the setting.
  Status verify_config();
  Status apply_config();
  Result<Response> transact(const std::vector<std::uint8_t>& command, Expect expect, std::uint8_t reg,
                            std::uint8_t size = 0);
  Status write_reg(std::uint8_t reg, std::span<const std::uint8_t> data);
  void flush_input();
  void stream_loop();
  void reopen();  // after an unplug: the session's Morph opened and configured again, or nothing
  void emit(SenselEvent::Kind kind, std::string message);
  void emit(SenselEvent e);

  TransportFactory factory_;
  EventHandler on_event_;
  std::unique_ptr<Transport> transport_;
  std::vector<std::uint8_t> inbox_;  // bytes read but not yet parsed
  bool timed_out_ = false;           // the last transact() failed for lack of an answer, not of a device
  HostNs first_byte_;                // when the last transact()'s answer began to arrive
  SenselInfo info_;
  SenselConfig config_;
  BoundedQueue<PressureSample> queue_;
  std::vector<std::uint64_t> dropped_;  // sequences dropped since the last sample queued (this connection's)
  std::uint32_t connection_ = 0;
  std::string session_serial_;  // the Morph the session streams from: a reconnect must find this one
  std::string refused_serial_;  // the other Morph last refused (its message is given once)
  std::string refused_settings_;  // the last reconnection refused for its settings (said once)
  Grid session_grid_;
  HostNs unplugged_at_;
  std::int64_t first_device_ns_ = -1, last_device_ns_ = 0;  // this connection's, for its frame rate
  std::uint64_t connection_frames_ = 0;
  std::int64_t frame_period_ns_ = 8'000'000;  // measured before an unplug (medium detail's by default)
  SequenceUnwrapper counter_{8, false};
  SequenceUnwrapper clock_{32, false};
  std::atomic<bool> running_{false};
  std::thread thread_;
  std::atomic<std::uint64_t> frames_{0}, lost_{0}, overflows_{0};
  mutable std::mutex rejected_mu_;
  std::map<std::string, std::uint64_t> rejected_;
};

// Of `candidates` (tty paths), the one whose Morph has serial `serial` (register 0x0F): each is
// opened, asked without a reset and closed; a port another pvcap holds is skipped untouched.
Result<std::string> find_tty_with_serial(const std::string& serial, const std::vector<std::string>& candidates);

}  // namespace pvcap::sensel
