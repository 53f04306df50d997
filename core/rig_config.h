#pragma once
// The rig description (rig-configs/*.yaml): which cameras, how to set them up,
// how to store, and, for the simulated rig, how the simulated devices behave.
// Parsing rejects unknown keys and names file:line and key in every error.
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace pvcap {

enum class TriggerMode { FreeRun, Software, Hardware };
const char* to_string(TriggerMode mode);

struct CameraConfig {
  std::string name;     // short label used in file names and messages, e.g. "cam0"
  std::string serial;   // match by serial number, or
  std::string address;  // by IPv4 address (one of the two is required)
  std::string pixel_format = "BayerRG8";
  int width = 1920;
  int height = 1080;
  int offset_x = 0;
  int offset_y = 0;
  double frame_rate = 60.0;   // Hz; free-run rate (ignored when triggered)
  double exposure_us = 8000;  // µs
  double gain = 0;            // camera units (dB on most GigE cameras)
  TriggerMode trigger = TriggerMode::FreeRun;
  std::string trigger_source = "Line0";  // for TriggerMode::Hardware
  int packet_size = 0;                   // bytes; 0 = negotiate the largest that works
  int socket_buffer_bytes = 0;           // 0 = let Aravis size it from the payload
  bool packet_resend = true;
  int buffer_count = 0;   // 0 = about half a second of frames, at least 8
  double link_mbps = 1000;  // the camera's link: preflight refuses a payload x rate above it
  std::int64_t latency_ns = 0;  // known constant exposure-to-timestamp latency (datasheet)
  int line = 0;           // where in the file this camera is described
  std::string id() const { return !serial.empty() ? serial : address; }
};

struct SenselRigConfig {
  // Where the Morph is: exactly one of
  std::string tty;              // /dev/ttyACM0 (or a udev name such as /dev/morph0); "sim": the simulator's
  std::optional<std::string> usb_serial;  // over libusb, by USB serial string; "" = the only Morph on the bus
  int scan_detail = 1;          // 0 high (93x53, ~50 Hz), 1 medium (47x27, ~125 Hz)
  bool dynamic_baseline = false;  // off: a resting hand must not fade away
  int frame_rate_cap = 0;       // Hz, 0 = the device's default
  std::int64_t latency_ns = 0;  // known constant scan-to-answer latency
  int line = 0;
};

struct SimSenselConfig {
  double press_x_mm = 115, press_y_mm = 65;  // where the simulated fingertip presses (sensor mm)
  double peak_grams = 300;                   // on its centre cell
  double period_s = 2.0;                     // one press and release per period
  double clock_start_us = 4294967295.0 - 3e6;  // device clock at start: wraps 3 s in
  double drift_ppm = 30;
  double usb_jitter_mean_ms = 0.5;  // arrival delay after the scan (exponential)...
  double usb_jitter_max_ms = 4.0;   // ...with a tail up to this
  double drop_fraction = 0;         // frames the device scans but loses (its counter skips them)
  std::optional<double> clock_reset_at_s;  // the device clock restarts at 0 this long after start
  // Unplugged this long after start, and plugged back (power-cycled: counter and clock restart) after
  // `replug_after_s` on a new pseudo-terminal, as `replug_serial` if given (another Morph), and under
  // another name if `replug_renamed` (its first name is gone, as ttyACM0 coming back as ttyACM1).
  std::optional<double> unplug_at_s, replug_after_s;
  std::optional<std::string> replug_serial;
  bool replug_renamed = false;
};

struct StoreConfig {
  // "raw": a Bayer camera's mosaic stored losslessly (its four planes, `raw_codec`), demosaiced when
  // read; "color": debayered on the capture path and stored with `video_codec` (lossy by default).
  // Cameras that send colour or grey pixels always take the colour path.
  std::string video_mode = "raw";
  std::string raw_codec = "ffvhuff";    // lossless, intra-only: ffvhuff (fastest here), ffv1, libx264 (qp 0)
  std::string video_codec = "libx264";  // colour mode: any FFmpeg encoder; "ffv1" for lossless
  int crf = 10;                         // libx264 quality (lower is better; 0 = lossless)
  std::string preset = "ultrafast";     // libx264 speed preset: real time for 4 x 1080p at 15 Hz on 2 cores
  std::string video_pixel_format = "yuv444p";  // keep full chroma: skin colour is the signal
  double video_fps = 15.0;  // frames kept in video per second per camera; 0 = every frame
  // Key frame interval in tenths of a second (<= 1 s). Half a second: a random access decodes half as
  // many frames, and on a real (noisy) sensor key frames cost little more than the others (+5 % size).
  int gop_seconds_x10 = 5;
  int queue_frames = 24;     // per-camera frames waiting for the encoder in memory; beyond them, the spill on disk
  double segment_seconds = 60;  // a camera's video is cut into files this long; 0 = one file
  int min_free_mb = 512;     // stop the session cleanly when the disk's free space drops below this
  int reserve_mb = 32;       // space set aside at start, freed to finish the store if the disk fills anyway
};

struct SimCameraClock {
  double offset_ms = 0;   // device clock minus true time at t = 0
  double drift_ppm = 0;   // device clock rate error
  double jitter_us = 0;   // std-dev of device timestamp noise
  double packet_loss = 0;  // fraction of GVSP packets not sent
  double exposure_latency_ms = 0;  // the instant a frame shows lies this long before it leaves (its "datasheet" latency)
  // A latency nobody declared: each frame shows the scene this long before the instant its timestamp
  // says (negative: after), so the sessions's clocks agree while the pixels lag; the report's sync
  // self-check must find it from the data alone.
  double undeclared_latency_ms = 0;
  std::optional<double> stop_after_s;    // camera vanishes after this many seconds (from sim start)
  std::optional<double> return_after_s;  // and comes back (power-cycled: frame ids restart) after this many
  bool trigger_line = true;              // wired to the rig's trigger line (used with trigger: hardware)
  // Its lens and where it stands (pad coordinates in mm, z = height above the pad); any left out
  // take the default of the camera's position in the rig (see sim/camera_views.cpp).
  std::optional<std::array<double, 3>> position_mm, look_at_mm;
  std::optional<double> focal_px;                      // at the configured image width
  std::optional<std::array<double, 5>> distortion;     // k1, k2, p1, p2, k3 (OpenCV's order)
};

struct SimConfig {
  std::vector<SimCameraClock> cameras;  // one per rig camera, same order
  SimSenselConfig sensel;
  std::uint64_t seed = 1;
  // Set: the simulated devices re-serve this recorded session instead of a scene (`pvcap replay
  // SESSION --as-devices` writes such a rig file); `replay_rate` > 1 plays it faster.
  std::optional<std::filesystem::path> replay;
  double replay_rate = 1.0;
};

struct RigConfig {
  std::filesystem::path source;  // the file it came from
  std::string text;              // the file's text, stored with each session
  std::string name;
  std::vector<CameraConfig> cameras;
  std::optional<SenselRigConfig> sensel;
  StoreConfig store;
  std::optional<SimConfig> sim;  // present for a simulated rig
};

// The rate of the session's sample grid: the store's video_fps, or the fastest camera's rate when
// every frame is kept (video_fps 0), or 60 Hz for a rig without cameras.
double sample_rate_hz(const RigConfig& rig);

// Loads and validates a rig file. Throws UserError("file:line: key: problem").
RigConfig load_rig_config(const std::filesystem::path& path);
// The same from text (tests, fuzzing); `source` names it in messages.
RigConfig parse_rig_config(const std::string& text, const std::filesystem::path& source);

}  // namespace pvcap
