#pragma once
// The store's record vocabulary: what a session's index holds, one struct per kind of row. Plain
// values, no SQLite: the protocol runner, the pipelines and the readers name records through this
// header; storage/index/session_index.h writes them (docs/store.md: the tables).
#include <cctype>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace pvcap {

struct SessionRecord {
  std::int64_t started_wall_ns = 0;
  std::int64_t started_host_ns = 0;
  std::string pvcap_version;
  std::string rig_name;
  std::string rig_path;
  std::string rig_config;  // the YAML text as loaded
  bool simulated = false;
};

struct DeviceRecord {
  std::string kind;  // "camera"
  std::string name, vendor, model, serial, address, firmware;
  std::string settings_json;  // what the device reported after configuration
};

// One video segment of one camera. Its id is chosen by the writer (segments open on the
// encoder's thread, their rows are written on the index's); frames name it in video_file_id.
struct VideoFileRecord {
  std::int64_t id = 0;
  std::int64_t device_id = 0;
  std::string path;                 // relative to the session directory
  std::string codec, pixel_format;  // what the file's codec holds ("gray" for raw videos)
  int width = 0, height = 0;        // the camera's image (a raw video's mosaic)
  int segment = 0;
  // "bgr": debayered colour; "bayer_planes": the sensor's mosaic, lossless (storage/video/bayer_planes.h)
  std::string layout = "bgr";
  std::optional<std::string> bayer_format;  // raw videos: the pattern as PFNC names it ("BayerRG8")
  std::optional<int> bit_depth;             // raw videos: bits per sample
  bool operator==(const VideoFileRecord&) const = default;
};
// A segment finished cleanly (trailer written): how many frames it holds.
struct VideoFileClosed {
  std::int64_t id = 0;
  std::int64_t frames = 0;
  bool operator==(const VideoFileClosed&) const = default;
};

struct FrameRecord {
  std::int64_t device_id = 0;
  std::uint32_t connection = 0;
  std::uint64_t sequence = 0;  // unwrapped frame id within the connection
  std::uint64_t frame_id = 0;  // as sent by the camera
  std::int64_t device_ns = 0;
  std::int64_t host_ns = 0;
  std::int64_t aravis_system_ns = 0;
  std::string status;  // good | incomplete
  bool kept = false;   // pixels are in the video
  std::string reason;  // why not kept (or why incomplete)
  std::optional<std::int64_t> video_file_id;
  std::optional<std::int64_t> video_index;   // 0-based frame number in that file
  std::optional<std::int64_t> mapped_ns;     // on the session clock (the clock model's), when known
  std::optional<std::int64_t> video_pts_ms;  // its timestamp in the video file, exactly
  // CRC-32 of the picture kept in a raw video, taken at capture (storage/video/frame_checksum.h)
  std::optional<std::uint32_t> checksum;
  // The frame's own state from its chunk data, where the camera sent it (capture/aravis_chunks.h):
  // the camera's frame counter, its timestamp (device ticks), exposure (us) and gain; and its lines'
  // levels as the frame was taken (bit N: LineN high; store version 7).
  std::optional<std::int64_t> chunk_frame_counter;
  std::optional<std::int64_t> chunk_timestamp;
  std::optional<double> chunk_exposure_us;
  std::optional<double> chunk_gain;
  std::optional<std::int64_t> chunk_line_status;
  bool operator==(const FrameRecord&) const = default;
};

// In a session folder while it is being recorded; flock()ed by the recording process.
inline constexpr const char* kRecordingLock = "recording.lock";
// The session folder's spill/: frames waiting for their encoder, and index rows waiting for the
// index (storage/writer/frame_spill.h, index_journal.h, index_overflow.h).
inline constexpr const char* kSpillFolder = "spill";

// A kept frame's timestamp in its video, in ms: `video_pts_ms` (exact) when the row has it; a
// store before it (version < 3) wrote round((host_ns - started_host_ns) / 1e6), within 1 ms.
struct VideoTimestamp {
  std::int64_t ms = 0;
  std::int64_t tolerance_ms = 0;
};
inline VideoTimestamp video_timestamp(std::optional<std::int64_t> video_pts_ms, std::int64_t host_ns,
                                      std::int64_t started_host_ns) {
  if (video_pts_ms) return {*video_pts_ms, 0};
  const std::int64_t us = (host_ns - started_host_ns) / 1000;
  return {(us + (us >= 0 ? 500 : -500)) / 1000, 1};
}

// One Sensel frame at full rate. `payload` is the frame exactly as the device sent it (the
// device's own lossless compression: raw counts on the native grid, contacts, accelerometer,
// labels; decode it with codec/sensel_frame.h on the grid stored beside it). `counts` are
// its raw counts again, stored zlib-compressed (storage/index/pressure_blob.h) for readers without
// the Sensel codec; empty when the frame carried no pressure image.
struct PressureRecord {
  std::int64_t device_id = 0;
  std::uint32_t connection = 0;
  std::uint64_t sequence = 0;     // rolling counter, unwrapped
  std::uint64_t lost_before = 0;  // frames the counter skipped before this one
  std::int64_t device_ns = 0;     // device µs clock, unwrapped, in ns
  std::int64_t host_ns = 0;       // midpoint of request and answer
  std::int64_t host_wait_ns = 0;  // request-to-answer time
  int grid_cols = 0, grid_rows = 0, grid_xscale = 0, grid_yscale = 0;
  std::vector<std::uint8_t> payload;
  std::optional<std::int64_t> mapped_ns;  // on the session clock (the clock model's)
  std::uint16_t base = 0;
  std::vector<std::uint16_t> counts;
  std::optional<std::uint32_t> checksum;  // CRC-32 of `payload` as received (storage/video/frame_checksum.h)
  bool operator==(const PressureRecord&) const = default;
};

// One 15 Hz dataset sample: a camera frame per camera for one instant, and the pressure
// frames around it. Frames are named by (device, connection, sequence), as in their tables.
struct SampleFrameRef {
  std::int64_t device_id = 0;
  std::uint32_t connection = 0;
  std::uint64_t sequence = 0;
  std::int64_t offset_ns = 0;  // frame's mapped time minus the sample's
  bool operator==(const SampleFrameRef&) const = default;
};
struct SampleRecord {
  std::uint64_t index = 0;
  std::int64_t tick = 0, tick_ns = 0;  // the grid tick it serves
  std::int64_t t_ns = 0;               // the instant (mean of its camera frames' mapped times)
  std::int64_t span_ns = 0;            // latest minus earliest camera frame
  std::vector<SampleFrameRef> cameras;
  std::optional<SampleFrameRef> pressure, pressure_before, pressure_after;  // nearest; neighbours
  bool operator==(const SampleRecord&) const = default;
};

// A stream's clock model at one moment: host = device + offset + skew * (device - x0) - latency.
struct ClockModelRecord {
  std::int64_t device_id = 0;
  std::int64_t host_ns = 0;
  int segment = 0;
  std::int64_t x0_device_ns = 0;
  double offset_ns = 0, skew = 0;
  std::int64_t latency_ns = 0;
  std::string source;  // "arrivals" (the envelope of arrival times) or "latch" (clock probes)
  std::uint64_t pairs = 0, envelope_points = 0;
  std::int64_t residual_p50_ns = 0, residual_p99_ns = 0;
  bool operator==(const ClockModelRecord&) const = default;
};

struct DropRecord {
  std::int64_t device_id = 0;
  std::uint32_t connection = 0;
  std::uint64_t first_sequence = 0;
  std::uint64_t count = 0;
  std::string reason;
  std::int64_t host_ns = 0;  // when the drop was noticed
  bool operator==(const DropRecord&) const = default;
};

struct EventRecord {
  std::int64_t host_ns = 0;
  std::string kind;
  std::optional<std::int64_t> device_id;
  std::string message;
  bool operator==(const EventRecord&) const = default;
};

// Who sat in the chair and under what conditions (one row each per session).
struct ParticipantRecord {
  std::string pseudonym;   // never a name: the lab's participant code
  std::string skin_tone;   // light | medium | dark | unrecorded (the paper's three categories)
  std::string hand_order;  // right_first | left_first | unrecorded
};
// A participant code as pvcap accepts it: 1 to 32 letters, digits, '-' or '_', starting with a
// letter or digit (e.g. P017, SIM01). A name with a space is refused before anything is recorded.
inline bool is_pseudonymous_code(const std::string& s) {
  if (s.empty() || s.size() > 32 || !std::isalnum(static_cast<unsigned char>(s[0]))) return false;
  for (char c : s)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') return false;
  return true;
}

struct ConditionsRecord {
  std::string lighting;        // which lights were on, e.g. "LCR", "L-R"
  std::string sensor_overlay;  // e.g. white_vinyl, wood
};

// A sensor-to-camera homography (sensor mm -> image px), row-major 3x3 in JSON.
struct CalibrationRecord {
  std::int64_t device_id = 0;
  std::int64_t created_wall_ns = 0;
  std::string method;
  std::string homography_json;
  std::optional<double> rms_px, rms_mm;
  std::string details_json = "{}";
};

// What the protocol runner did, on the capture clock (kind: prompt, action_start, action_end,
// redo, skip, pause, resume, mark_bad, hand_switch, ...).
struct ProtocolEventRecord {
  std::int64_t host_ns = 0;
  std::string kind;
  std::optional<std::int64_t> step;
  std::string action, hand, force;
  std::optional<std::int64_t> repetition;
  std::string detail;
  bool operator==(const ProtocolEventRecord&) const = default;
};

struct OperatorNoteRecord {
  std::int64_t host_ns = 0;
  std::string text;
  bool operator==(const OperatorNoteRecord&) const = default;
};

struct StreamStatsRecord {
  std::int64_t device_id = 0;
  std::uint64_t completed = 0, failures = 0, underruns = 0, resent_packets = 0, missing_packets = 0,
                queue_overflows = 0;
};

}  // namespace pvcap
