#pragma once
// A Sensel Morph that speaks the device's protocol (protocol spec §12): a
// byte-addressed register file with the documented defaults and soft reset, the
// command parser with acks and checksums, and frames built with the same
// encoders the driver's decoder is tested against, from a pressure scene, on the
// emulator's own clock. Transport-free: feed it host bytes, send back what it
// returns (sensel_pty.h puts it behind a pseudo-terminal).
#include <array>
#include <atomic>
#include <climits>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <ostream>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "codec/sensel_frame.h"
#include "codec/sensel_pressure_codec.h"
#include "sim/session_replay.h"

namespace pvcap::sim {

struct SenselScene {
  // Raw counts on `grid` at true time `true_ns` (row-major); empty = nothing on the pad.
  std::function<std::vector<std::uint16_t>(std::int64_t true_ns, const sensel::Grid& grid)> pressure;
};
// A fingertip pressing at (x_mm, y_mm) once every `period_s`, peaking at `peak_grams` on its
// centre cell: a smooth press and release, nothing in between.
SenselScene fingertip_scene(double x_mm, double y_mm, double peak_grams, double period_s);
class Hand;
// The pressure of a simulated hand (sim/hand.h), wherever it is steered.
SenselScene hand_scene(std::shared_ptr<const Hand> hand);

struct SenselClock {
  std::int64_t t0_ns = 0;  // true time of the emulator's power-on
  double start_us = 0;     // device timestamp at power-on (set near 2^32 to test the wrap)
  double drift_ppm = 0;
  std::int64_t reset_at_ns = INT64_MAX;  // true time the clock restarts from 0 (a brown-out, a firmware reset)
  std::uint32_t at(std::int64_t true_ns) const {
    const double rate = 1.0 + drift_ppm * 1e-6;
    if (true_ns >= reset_at_ns) return std::uint32_t(std::uint64_t(double(true_ns - reset_at_ns) / 1e3 * rate));
    return std::uint32_t(std::uint64_t(start_us + double(true_ns - t0_ns) / 1e3 * rate));
  }
};

class SenselEmulator {
 public:
  SenselEmulator(SenselScene scene, SenselClock clock, std::string serial = kDefaultSerial);
  static constexpr const char* kDefaultSerial = "SM01164910368";  // the Morph the specs' captures came from

  // Consumes host bytes; returns the device's answers (empty while a command is incomplete).
  std::vector<std::uint8_t> on_host_bytes(std::span<const std::uint8_t> bytes, std::int64_t now_ns);

  // Async scanning (SCAN_ENABLED = 2): the frames due by `now_ns`, each `09 26 00 len payload chk`,
  // to be pushed without a request. Empty in the other modes.
  std::vector<std::uint8_t> async_frames_due(std::int64_t now_ns);
  // Nanoseconds per scan at the current detail (the device's measured floor; payload slows high detail).
  std::int64_t scan_period_ns(std::size_t payload_bytes) const;

  // Faults for tests: the next frame's checksum is wrong / the next frame is cut short.
  void corrupt_next_frame() { corrupt_next_ = true; }
  void truncate_next_frame() { truncate_next_ = true; }
  // A Morph that falls back to medium detail whenever a scan starts (seen after a stop or a reset).
  void revert_detail_on_scan_start() { revert_detail_on_start_ = true; }
  // Writes to `reg` are acknowledged but change nothing (a setting that does not take).
  void ignore_writes_to(std::uint8_t reg) { ignored_reg_ = reg; }
  // Loses this fraction of scans inside the device (its counter skips them), seeded.
  void set_drop_fraction(double fraction, std::uint64_t seed) {
    drop_fraction_ = fraction;
    drop_rng_.seed(seed);
  }

  // Replay (sim/session_replay.h): frame reads answer with the session's recorded payloads, in
  // order, each when it is due; the scene and the clock are not used. When they run out, frame
  // reads go unanswered (a silent device).
  void set_replay(std::shared_ptr<SessionReplay> replay) { replay_ = std::move(replay); }
  bool replaying() const { return bool(replay_); }
  // When the next recorded frame is due (host time); the first call starts the replay at `now_ns`
  // and passes over frames due before it. Empty when the recording is over.
  std::optional<std::int64_t> replay_due(std::int64_t now_ns);
  // The last replayed frame left the transport at `host_ns`: logged to the truth log (set_truth_log)
  // as "counter,device_us,due_ns,sent_ns,asked_ns,woke_ns" (asked: when its read request came in;
  // a request that comes after the frame is due makes it late; woke: when the transport's thread,
  // asleep until the frame was due, ran again: a late wake is the host's, not the emulator's).
  void replay_sent(std::int64_t asked_ns, std::int64_t woke_ns, std::int64_t host_ns);

  sensel::Grid grid() const;  // of the current scan detail
  // Ground truth: one line "counter,true_ns,device_us" per frame sent (flushed every 32).
  void set_truth_log(std::ostream* out) { truth_ = out; }
  std::uint8_t reg(std::uint8_t address) const { return regs_[address]; }
  // The last complete variable-size write (WVS) to `address` (e.g. LED_BRIGHTNESS, 0x80).
  std::vector<std::uint8_t> variable_reg(std::uint8_t address) const;
  std::uint64_t frames_sent() const { return frames_sent_; }

 private:
  void soft_reset();
  std::vector<std::uint8_t> frame_payload(std::int64_t now_ns);
  std::vector<std::uint8_t> read_variable(std::uint8_t reg, std::int64_t now_ns);

  SenselScene scene_;
  SenselClock clock_;
  std::string serial_;
  std::array<std::uint8_t, 256> regs_{};
  std::vector<std::uint8_t> pending_;  // host bytes not yet forming a whole command
  double drop_fraction_ = 0;
  std::mt19937_64 drop_rng_;
  struct VariableWrite {
    std::uint8_t reg = 0;
    std::uint32_t left = 0;  // bytes still to come in chunks; 0 = no WVS in progress
    std::vector<std::uint8_t> data;
  } wvs_;
  std::map<std::uint8_t, std::vector<std::uint8_t>> variable_regs_;
  std::ostream* truth_ = nullptr;
  std::uint8_t counter_ = 0;
  std::int64_t next_scan_ns_ = 0;  // buffered and async modes: when the next scan completes
  std::uint64_t frames_sent_ = 0;
  std::atomic<bool> corrupt_next_{false}, truncate_next_{false};  // set from test threads
  bool revert_detail_on_start_ = false;
  int ignored_reg_ = -1;
  std::shared_ptr<SessionReplay> replay_;
  std::size_t replay_next_ = 0;
  std::uint64_t replay_logged_ = 0;
  bool replay_started_ = false;
};

}  // namespace pvcap::sim
