#pragma once
// The rig description (rig-configs/*.yaml): which cameras, how to set them up,
// how to store. A simulated rig's `sim:` section (how its simulated devices behave)
// is the simulator's own: sim/sim_config.h reads it; here it only marks the rig simulated.
// Parsing rejects unknown keys and names file:line and key in every error.
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace pvcap {

enum class TriggerMode { FreeRun, Software, Hardware };
enum class TimestampMarks { ExposureStart, ExposureMiddle, ExposureEnd };
// From the instant the stamp marks to the middle of an exposure of `exposure_us`.
std::int64_t stamp_to_mid_exposure_ns(TimestampMarks marks, double exposure_us);
const char* to_string(TimestampMarks marks);  // "exposure_start", ...
const char* to_string(TriggerMode mode);

// A light the rig switches through a camera's output line (docs/cameras.md, "Lights"): its name is a
// letter of the lighting codes (L, C, R: `--lighting LCR`), the camera and the line that drive it,
// and whether it is lit steadily (a user output: on or off between takes) or strobed, lit during each
// exposure of that camera.
// The number that ends an I/O line's name (Line2 -> 2, SyncOut1 -> 1); -1 without one (or one too
// long to be a line's). A light's line, and its bit in a frame's line levels (LineStatusAll).
int line_number(const std::string& line);

struct LightConfig {
  std::string name;
  std::string camera;
  std::string line;  // the camera's output line, under its map's own name (Line2, SyncOut1)
  bool strobe = false;
  int line_no = 0;  // where in the file this light is described
};

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
  // Each frame's counter, timestamp, exposure and gain from its chunk data, where the camera offers
  // them (stored with the frame's row); off: chunk mode is left off.
  bool chunk_data = true;
  int buffer_count = 0;     // 0 = about half a second of frames, at least 8
  double link_mbps = 1000;  // the camera's link: preflight refuses a payload x rate above it
  // A link shared with the rig's other cameras of the same name (a NIC port behind a switch, a switch's
  // uplink): together they must fit link_mbps, and each is paced to its share of it (a packet delay,
  // or the camera's own throughput limit), so that their frames' bursts do not overflow the port.
  // "" = a link of its own. link_cameras: how many cameras share it (counted by the rig loader).
  std::string link;
  int link_cameras = 1;
  std::vector<LightConfig> lights;   // the rig's lights this camera drives (the rig loader fills it)
  bool rig_switches_lights = false;  // the rig has lights: no automatic exposure or gain may hide them
  bool ptp = false;  // the rig's ptp.cameras: PTP enabled, locked before the session, read each second
  // What the camera's frame timestamp marks: SFNC and GigE Vision cameras stamp a frame when its
  // exposure starts (the Basler ace 2's map says so), so the image's instant, the middle of its
  // exposure, is half the exposure later (docs/cameras.md: the vendors' exceptions).
  TimestampMarks timestamp_marks = TimestampMarks::ExposureStart;
  // Without a timestamp latch: the known constant latency from what the stamp marks to the frame's
  // leader packet leaving the camera (datasheet).
  std::int64_t latency_ns = 0;
  int line = 0;  // where in the file this camera is described
  std::string id() const { return !serial.empty() ? serial : address; }
};

struct SenselRigConfig {
  // Where the Morph is: exactly one of
  std::string tty;                        // /dev/ttyACM0 (or a udev name such as /dev/morph0); "sim": the simulator's
                                          // (resolved to its pseudo-terminal before a recording opens it)
  std::optional<std::string> usb_serial;  // over libusb, by USB serial string; "" = the only Morph on the bus
  int scan_detail = 1;                    // 0 high (93x53, ~50 Hz), 1 medium (47x27, ~125 Hz)
  bool dynamic_baseline = false;          // off: a resting hand must not fade away
  int frame_rate_cap = 0;                 // Hz, 0 = the device's default
  std::int64_t latency_ns = 0;            // known constant scan-to-answer latency
  int line = 0;
};

struct StoreConfig {
  // "raw": a Bayer camera's mosaic stored losslessly (its four planes, `raw_codec`), demosaiced when
  // read; "color": debayered on the capture path and stored with `video_codec` (lossy by default).
  // Cameras that send colour or grey pixels always take the colour path.
  std::string video_mode = "raw";
  // Lossless, intra-only: ffvhuff (the default), magicyuv (8-bit only; 7 % smaller on noisy 1080p
  // mosaics at a similar speed, bench/lossless_bench), ffv1, libx264 (qp 0; up to 10 bits).
  std::string raw_codec = "ffvhuff";
  // Raw mode: the mosaic stored as a grid of tiles, each its own stream, so that a crop decodes only
  // the tiles under it (storage/video/bayer_tiles.h). 0 x 0 ("auto"): tiles of about 240 x 180
  // pixels, 8 x 6 for a 1080p camera; 1 x 1: one picture per frame.
  int raw_tile_cols = 0, raw_tile_rows = 0;
  std::string video_codec = "libx264";         // colour mode: any FFmpeg encoder; "ffv1" for lossless
  int crf = 10;                                // libx264 quality (lower is better; 0 = lossless)
  std::string preset = "ultrafast";            // libx264 speed preset: real time for 4 x 1080p at 15 Hz on 2 cores
  std::string video_pixel_format = "yuv444p";  // keep full chroma: skin colour is the signal
  double video_fps = 15.0;                     // frames kept in video per second per camera; 0 = every frame
  // Key frame interval in tenths of a second (<= 1 s). Half a second: a random access decodes half as
  // many frames, and on a real (noisy) sensor key frames cost little more than the others (+5 % size).
  int gop_seconds_x10 = 5;
  int queue_frames = 24;        // per-camera frames waiting for the encoder in memory; beyond them, the spill on disk
  double segment_seconds = 60;  // a camera's video is cut into files this long; 0 = one file
  int min_free_mb = 512;        // stop the session cleanly when the disk's free space drops below this
  int reserve_mb = 32;          // space set aside at start, freed to finish the store if the disk fills anyway
  // Every file of the session reaches stable storage at least this often while recording (fsync,
  // core/durable_folder.h): what a power cut can lose. 0 leaves it to the kernel (benchmarks).
  double sync_interval_s = 0.5;
  // The group a session folder belongs to (its files follow: the folder is setgid), for a lab whose
  // members read each other's sessions; empty: the recorder's own group. Others read nothing.
  std::string group;
  // Beside each camera's video, a small colour copy of its frames (at most 640 x 360, H.264,
  // storage/video/view_video.h) that the replay shows instead of decoding the whole picture. Skipped
  // while more than two of the camera's frames wait for its encoder.
  bool view_videos = true;
};

// The host's PTP time (docs/multihost.md): read from linuxptp's ptp4l through `pmc` before the
// session (a host out of time is refused) and every second while it records (sync/ptp_host.h).
struct PtpRigConfig {
  bool host = true;     // the host's ptp4l is read (through pmc)
  bool cameras = true;  // every camera's PTP enabled, each locked before the session starts
  double lock_wait_s = 10;  // how long the cameras may take to lock before the session is refused
  std::string ptp4l_socket = "/var/run/ptp4l";  // ptp4l's uds_address
  // The largest offset from its master at which the host counts as in time: 1 us for hardware
  // timestamping; software timestamping (a NIC without a PTP clock) needs tens of microseconds.
  double max_offset_us = 1.0;
  int line = 0;
};

struct RigConfig {
  std::filesystem::path source;  // the file it came from
  std::string text;              // the file's text, stored with each session
  std::string name;
  std::vector<CameraConfig> cameras;
  std::vector<LightConfig> lights;
  std::optional<SenselRigConfig> sensel;
  StoreConfig store;
  std::optional<PtpRigConfig> ptp;  // a `ptp:` section: the host's PTP time is read and stored
  // The file has a `sim:` section: its devices are served by the simulator (sim/sim_config.h reads
  // the section; app/'s rig launcher starts it).
  bool simulated = false;
};

// The rate of the session's sample grid: the store's video_fps, or the fastest camera's rate when
// every frame is kept (video_fps 0), or 60 Hz for a rig without cameras.
double sample_rate_hz(const RigConfig& rig);

// The rate whose half period bounds a group of camera frames (one instant): the fastest camera's,
// or 60 Hz for a rig without cameras. The live grouper and the end-of-session re-mapping use it alike.
double grouping_rate_hz(const RigConfig& rig);

// Loads and validates a rig file. Throws UserError("file:line: key: problem").
RigConfig load_rig_config(const std::filesystem::path& path);
// The same from text (tests, fuzzing); `source` names it in messages.
RigConfig parse_rig_config(const std::string& text, const std::filesystem::path& source);

}  // namespace pvcap
