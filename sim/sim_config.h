#pragma once
// A simulated rig's `sim:` section: how its simulated devices behave (clocks, faults, lenses, the
// Sensel's pressing fingertip, or a recorded session to re-serve). The product's rig reader
// (core/rig_config.h) only notes that the section is there; the simulator reads it here, as
// strictly (unknown keys are errors, each naming file:line and key).
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/rig_config.h"

namespace pvcap::sim {

struct SimSenselConfig {
  // How the emulated Morph reaches the recording: "pty", a pseudo-terminal (as /dev/ttyACM0), or
  // "usb", umockdev's emulated USB bus (as over libusb; the recording starts itself again under
  // umockdev's preload library). Both can hold the Morph's bytes back on a saturated machine (the
  // pty's kernel worker runs at a normal priority; umockdev's preload guards its ioctl and path
  // handling with process-wide mutexes, the likely cause there), and usb costs about a third of a
  // core in socket round trips: docs/testing.md has the measurements.
  std::string transport = "pty";
  double press_x_mm = 115, press_y_mm = 65;    // where the simulated fingertip presses (sensor mm)
  double peak_grams = 300;                     // on its centre cell
  double period_s = 2.0;                       // one press and release per period
  double clock_start_us = 4294967295.0 - 3e6;  // device clock at start: wraps 3 s in
  double drift_ppm = 30;
  double usb_jitter_mean_ms = 0.5;         // arrival delay after the scan (exponential)...
  double usb_jitter_max_ms = 4.0;          // ...with a tail up to this
  double drop_fraction = 0;                // frames the device scans but loses (its counter skips them)
  std::optional<double> clock_reset_at_s;  // the device clock restarts at 0 this long after start
  // Unplugged this long after start, and plugged back (power-cycled: counter and clock restart) after
  // `replug_after_s` on a new pseudo-terminal (transport pty only), as `replug_serial` if given (another Morph), and
  // under another name if `replug_renamed` (its first name is gone, as ttyACM0 coming back as ttyACM1).
  std::optional<double> unplug_at_s, replug_after_s;
  std::optional<std::string> replug_serial;
  bool replug_renamed = false;
};

// How a simulated camera's node map names its features (sim/fake_camera_features.h).
enum class NodeMapNaming { Aravis, Sfnc2, RawExposure };

struct SimCameraClock {
  double offset_ms = 0;    // device clock minus true time at t = 0
  double drift_ppm = 0;    // device clock rate error
  double jitter_us = 0;    // std-dev of device timestamp noise
  double packet_loss = 0;  // fraction of GVSP packets not sent
  double exposure_latency_ms =
      0;  // the instant a frame shows lies this long before it leaves (its "datasheet" latency)
  // A latency nobody declared: each frame shows the scene this long before the instant its timestamp
  // says (negative: after), so the sessions's clocks agree while the pixels lag; the report's sync
  // self-check must find it from the data alone.
  double undeclared_latency_ms = 0;
  // Each frame's exposure alternates this far above and below the one set, a camera whose exposure
  // changes while it records (its read-back, once per connection, cannot say; its chunks can).
  double exposure_wobble_us = 0;
  std::optional<double> stop_after_s;    // camera vanishes after this many seconds (from sim start)
  std::optional<double> return_after_s;  // and comes back (power-cycled: frame ids restart) after this many
  // The outage again every `outage_every_s` after the first, `outages` times in all (with return_after_s).
  int outages = 1;
  double outage_every_s = 0;
  bool trigger_line = true;              // wired to the rig's trigger line (used with trigger: hardware)
  // Its node map's naming: "aravis" (Aravis' fake camera's: ExposureTimeAbs, GainRaw,
  // TimestampControlLatch), "sfnc2" (ExposureTime, Gain, TimestampLatch, AcquisitionFrameRateEnable)
  // or "raw" (Aravis' names with the exposure only as ExposureTimeRaw, in steps of ExposureTimeBaseAbs).
  NodeMapNaming node_map = NodeMapNaming::Aravis;
  bool white_balance_auto =
      false;  // sfnc2 only: its BalanceWhiteAuto is left Continuous (a camera set so by another program)
  // sfnc2 only (its PtpEnable, PtpStatus, PtpServoStatus, PtpDataSetLatch, PtpOffsetFromMaster):
  // once PTP is enabled it listens for `ptp_lock_after_s`, then follows the grandmaster locked, its
  // offset from its master each latch drawn with this standard deviation (the servo's error); from
  // `ptp_unlock_at_s` (seconds after it was enabled) it loses lock for `ptp_unlock_for_s`.
  double ptp_lock_after_s = 1.0;
  double ptp_servo_error_ns = 50.0;
  std::optional<double> ptp_unlock_at_s;
  double ptp_unlock_for_s = 5.0;
  // Its lens and where it stands (pad coordinates in mm, z = height above the pad); any left out
  // take the default of the camera's position in the rig (see sim/camera_views.cpp).
  std::optional<std::array<double, 3>> position_mm, look_at_mm;
  std::optional<double> focal_px;                   // at the configured image width
  std::optional<std::array<double, 5>> distortion;  // k1, k2, p1, p2, k3 (OpenCV's order)
};

struct SimConfig {
  std::vector<SimCameraClock> cameras;  // one per rig camera, same order
  SimSenselConfig sensel;
  std::uint64_t seed = 1;
  // Set: the simulated devices re-serve this recorded session instead of a scene (`pvcap replay
  // SESSION --as-devices` writes such a rig file); `replay_rate` > 1 plays it faster.
  std::optional<std::filesystem::path> replay;
  double replay_rate = 1.0;
  // Faults of the rig's lamps (sim/lights.h), from PVCAP_FAULTS (`sim.light_off=C`, `sim.light_lag_s=S`).
  std::string light_off;
  double light_lag_s = 0;
};

// The rig's `sim:` section (re-read from the rig file's text), or nullopt when it has none.
// Throws UserError("file:line: sim.key: problem").
std::optional<SimConfig> load_sim_config(const RigConfig& rig);

}  // namespace pvcap::sim
