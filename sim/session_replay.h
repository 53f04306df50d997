#pragma once
// A recorded session re-served through the simulated devices (a rig file with `sim: {replay:
// SESSION}`, which `pvcap replay SESSION --as-devices` writes). Each camera sends the frames it
// sent then, with their frame ids and device timestamps and, from a raw store, their mosaics bit
// for bit; the Sensel answers with the recorded wire frames. Each frame leaves at the instant it was
// recorded at on the session clock, plus one shift that is the same for every device: fixed when
// the first device starts streaming, and a whole number of sample periods from the original grid's
// anchor. A recorder anchors its grid on the same lattice (sync::grid_lattice_floor), so the
// re-recording samples the same instants: a regression check of the whole pipeline.
//
// The cameras' timestamp latches read the recorded clocks: device time interpolated between the
// recorded frames' (session time, device time) pairs, so the new session maps the frames onto its
// clock as the old one did. With `rate` != 1 the frames leave that much faster or slower, and their
// device timestamps (a camera's, the Sensel's in its payload) are scaled by it about each clock's
// start, so the device clocks still tick at their own rate: the same session at r times its frame
// rates, for a stress test (not a copy: the timestamps and the Sensel's payloads differ).
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "core/result.h"

namespace pvcap::sim {

struct ReplayCameraFrame {
  std::uint64_t frame_id = 0;
  std::int64_t device_ns = 0;
  std::int64_t t_ns = 0;     // when it was exposed, on the recorded session's clock
  std::int64_t sample = -1;  // the sample (SessionReader index) whose stored image it is; -1: not stored
};

struct ReplayPressureFrame {
  std::vector<std::uint8_t> payload;  // the frame read's payload as the device sent it
  std::int64_t t_ns = 0;              // when it was scanned, on the recorded session's clock
};

class SessionReplay {
 public:
  // Reads the session's index (not its videos: the cameras read their own pixels as they go).
  static Result<std::shared_ptr<SessionReplay>> open(const std::filesystem::path& session_dir, double rate = 1.0);

  const std::filesystem::path& dir() const { return dir_; }
  double rate() const { return rate_; }
  // Frames of the recorded camera of that name (an Error names the cameras the session has).
  Result<std::size_t> camera_index(const std::string& name) const;
  const std::vector<ReplayCameraFrame>& camera_frames(std::size_t c) const { return cameras_[c].frames; }
  bool has_pressure() const { return !pressure_.empty(); }
  const std::vector<ReplayPressureFrame>& pressure_frames() const { return pressure_; }
  const std::string& sensel_serial() const { return sensel_serial_; }

  // A device starts streaming, or its clock is read, at `now_ns`: the first call fixes the shift,
  // so that the session's first frame leaves 0.2 s later; every call returns it.
  std::int64_t start(std::int64_t now_ns);
  bool started() const;
  // When a frame recorded at session time `t_ns` leaves (host CLOCK_MONOTONIC); before start(),
  // as if it were starting now.
  std::int64_t due_ns(std::int64_t t_ns) const;
  // Camera c's device clock at host instant `host_ns`.
  std::int64_t camera_device_time(std::size_t c, std::int64_t host_ns) const;
  // The session time a host instant of the replay stands for.
  std::int64_t session_time(std::int64_t host_ns) const;

 private:
  SessionReplay() = default;
  std::int64_t origin_for(std::int64_t now_ns) const;
  std::int64_t origin() const;  // the host instant standing for the recorded anchor
  struct Camera {
    std::string name;
    std::vector<ReplayCameraFrame> frames;                     // in the order they were sent
    std::vector<std::pair<std::int64_t, std::int64_t>> clock;  // (t_ns, device_ns), by t_ns
  };
  std::filesystem::path dir_;
  double rate_ = 1.0;
  double grid_hz_ = 15.0;
  std::int64_t anchor_ns_ = 0;   // the recorded grid's anchor (session start)
  std::int64_t first_t_ns_ = 0;  // the earliest recorded frame of any device
  std::vector<Camera> cameras_;
  std::vector<ReplayPressureFrame> pressure_;
  std::string sensel_serial_;
  mutable std::mutex mu_;
  std::optional<std::int64_t> origin_;  // the host instant standing for anchor_ns_
};

}  // namespace pvcap::sim
