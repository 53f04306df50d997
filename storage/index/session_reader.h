#pragma once
// Reading a session store (C++): the API the replay, calibration and export tools use.
//
//   auto r = SessionReader::open(dir);            // Error for a missing, foreign, damaged or
//   for (std::size_t i = 0; i < r->sample_count(); ++i) {   // newer/older store; never a crash
//     auto s = r->sample(i, PressureMode::Interpolated);
//     s->images[c] ...  s->pressure->counts ...
//   }
//
// Samples are the 15 Hz dataset samples: one camera frame per camera for one instant on the
// session clock (CLOCK_MONOTONIC ns of the recording host, as every *_ns column), and the
// pressure frames around it. Read-only: a reader never changes a store.
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "codec/demosaic.h"
#include "core/result.h"
#include "storage/index/session_index.h"
#include "storage/video/view_video_reader.h"

namespace pvcap {

namespace sqlite {
class Database;
}
class VideoReader;

struct SessionInfo {
  int schema_version = 0;
  std::int64_t started_wall_ns = 0, started_host_ns = 0;
  std::optional<std::int64_t> ended_host_ns;  // empty: the recording did not end cleanly
  std::string end_reason, pvcap_version, rig_name, rig_config;
  std::string rig_path;  // the rig file it was recorded with, where it was then
  bool simulated = false;
  std::optional<ParticipantRecord> participant;
  std::optional<ConditionsRecord> conditions;
};

struct CameraInfo {
  std::int64_t device_id = 0;
  std::string name, serial;
  int width = 0, height = 0;
  // From the instant its stamps mark (the start of an exposure) to the image's (its middle); 0 in
  // sessions recorded before pvcap stored it.
  std::int64_t stamp_to_instant_ns = 0;
};

struct PressureDeviceInfo {
  std::int64_t device_id = 0;
  std::string name, serial;
};

// One pressure frame at full rate: raw counts on the device's native grid (row-major).
struct PressureFrame {
  std::uint64_t sequence = 0;
  std::int64_t device_ns = 0, host_ns = 0;
  std::optional<std::int64_t> mapped_ns;
  int grid_cols = 0, grid_rows = 0, grid_xscale = 0, grid_yscale = 0;
  std::uint16_t base = 0;
  std::vector<std::uint16_t> counts;
  cv::Mat image() const;  // CV_32F grid_rows x grid_cols view of the counts (a copy)
};

struct SampleCamera {
  std::int64_t device_id = 0;
  std::uint32_t connection = 0;
  std::uint64_t sequence = 0;
  std::int64_t offset_ns = 0;  // the frame's mapped time minus the sample's
  bool in_video = false;       // false: its pixels were not stored (reason says why)
  std::string reason;
};

struct SampleInfo {
  std::uint64_t index = 0;
  std::int64_t tick = 0, tick_ns = 0, t_ns = 0, span_ns = 0;
  std::vector<SampleCamera> cameras;  // in the order of cameras() (absent cameras missing)
  struct PressureRef {
    std::uint64_t sequence = 0;
    std::int64_t offset_ns = 0;
    std::uint32_t connection = 0;  // the Sensel's connection (one more after each replug); the same for all three
  };
  std::optional<PressureRef> pressure, before, after;  // nearest; the neighbours around t_ns
};

enum class PressureMode {
  Nearest,       // the frame nearest the sample's instant
  Interpolated,  // linear between the frames before and after it (nearest when one is missing)
};

struct Sample {
  SampleInfo info;
  std::vector<cv::Mat> images;            // BGR per cameras() entry; empty where the sample has no stored frame
  std::optional<PressureFrame> pressure;  // the nearest frame, as recorded
  cv::Mat pressure_image;                 // CV_32F native grid: the nearest frame's counts, or interpolated ones
};

struct ActionSpan {
  std::optional<std::int64_t> step;
  std::string action, hand, force;
  std::optional<std::int64_t> repetition;
  std::int64_t start_ns = 0, end_ns = 0;         // end: the action's end event, or the session's end
  std::size_t first_sample = 0, end_sample = 0;  // samples in [start_ns, end_ns): [first, end)
};

struct StreamStatistics {
  std::int64_t device_id = 0;
  std::string name, kind;
  std::uint64_t frames = 0;  // rows stored (camera: every received frame; sensel: every frame)
  std::uint64_t in_video = 0;
  std::uint64_t dropped = 0;                               // never reached the store (drops table)
  std::map<std::string, std::uint64_t> dropped_by_reason;  // not_received, queue_overflow, buffer_underrun, unplugged
  std::map<std::string, std::uint64_t> not_kept;           // camera frames not in a video, by reason
  std::map<std::string, std::uint64_t> by_status;          // camera frames by status (good, incomplete, ...)
  std::uint64_t connection_losses = 0;                     // camera_lost / sensel_unplugged events
  double mean_rate_hz = 0;
};

// When one frame of a stream came, for interval and clock plots (no pixels, no payload).
struct FrameTiming {
  std::uint32_t connection = 0;
  std::uint64_t sequence = 0;
  std::int64_t host_ns = 0, device_ns = 0;
  std::optional<std::int64_t> mapped_ns;
  bool good = true;               // camera: status 'good'
  bool kept = false;              // camera: in a video
  std::uint64_t frame_id = 0;     // camera: the id the camera sent it with
  std::int64_t host_wait_ns = 0;  // Sensel: request-to-answer time (host_ns is their midpoint)
  // Camera: the frame's own state from its chunk data (store version 6; absent where the camera sent
  // none): its counter, timestamp (device ticks), exposure (us) and gain; its lines' levels (bit N:
  // LineN high; version 7).
  std::optional<std::int64_t> chunk_frame_counter, chunk_timestamp;
  std::optional<double> chunk_exposure_us, chunk_gain;
  std::optional<std::int64_t> chunk_line_status;
};

// One pressure frame as the device sent it (the wire frame), on the session clock.
struct PressurePayload {
  std::uint32_t connection = 0;
  std::uint64_t sequence = 0;
  std::int64_t mapped_ns = 0;
  std::vector<std::uint8_t> payload;
};

// One pressure frame reduced to its instant and its sum of raw counts.
struct PressureTotal {
  std::uint64_t sequence = 0;
  std::int64_t t_ns = 0;  // mapped_ns (the session clock), host_ns where unmapped
  double total_counts = 0;
  std::uint32_t connection = 0;  // of the Sensel (one more after each replug)
};

class SessionReader {
 public:
  static Result<std::unique_ptr<SessionReader>> open(const std::filesystem::path& session_dir);
  ~SessionReader();
  SessionReader(const SessionReader&) = delete;
  SessionReader& operator=(const SessionReader&) = delete;

  const SessionInfo& info() const { return info_; }
  const std::vector<CameraInfo>& cameras() const { return cameras_; }
  const std::optional<PressureDeviceInfo>& pressure_device() const { return pressure_device_; }

  std::size_t sample_count() const { return sample_times_.size(); }
  Result<SampleInfo> sample_info(std::size_t i);
  // Decoded frames of every camera and the pressure, as `mode` asks.
  Result<Sample> sample(std::size_t i, PressureMode mode = PressureMode::Nearest);
  // One camera's image of sample i (`camera` indexes cameras()); empty when that frame was not stored.
  Result<cv::Mat> image(std::size_t i, std::size_t camera);
  // `box` of image(i, camera) (the camera's pixels; inside its image), the same pixels: from a raw
  // video read at its own size and demosaiced bilinearly (the defaults), only the box and a margin
  // are demosaiced (a crop of the pad is a sixth of a 1080p frame); otherwise the image is cut.
  Result<cv::Mat> image_region(std::size_t i, std::size_t camera, cv::Rect box);
  // The same frame as the sensor's Bayer mosaic (CV_8UC1), exactly as captured: raw videos only
  // (an Error for a colour video); empty when that frame was not stored.
  Result<cv::Mat> raw_image(std::size_t i, std::size_t camera);
  // How raw videos become the colour images above: bilinear (the default, as the capture path's
  // previews), edge-aware or VNG (codec/pixel_format.h).
  void set_demosaic(Demosaic method);
  // Colour images (image, sample) scaled to `size` (bilinear; empty, the default: their own size):
  // a viewer's, made at its size where the pixels are decoded (VideoReader::set_image_size).
  void set_image_size(cv::Size size) { image_size_ = size; }
  // Checks each raw video frame read (image, raw_image, sample) against the checksum its camera's
  // bytes got at capture (docs/store.md, Checksums): a frame whose pixels differ is an Error naming
  // it, never handed out. Off by default (one CRC per frame read: ~1 ms per 1080p frame).
  void set_check_checksums(bool on) { check_checksums_ = on; }
  // image() and sample() read a camera's frame from its view video (storage/video/view_video.h: at most
  // 640 x 360, lossy) where the session has one, and from its own video otherwise: for viewers that
  // show it at that size or smaller. Off by default; raw_image() and checked reads never do.
  void set_view_videos(bool on) { view_videos_ = on; }
  // Videos held open for reading: a camera's current segment and the one before, at most.
  std::size_t open_videos() const { return videos_.size(); }
  // The sample nearest `t_ns` on the session clock (info().started_host_ns + seconds * 1e9).
  Result<std::size_t> sample_at(std::int64_t t_ns) const;
  Result<PressureFrame> pressure_frame(std::uint64_t sequence, std::uint32_t connection = 0);
  // Every pressure frame whose time on the session clock is in [from_ns, to_ns), in order.
  Result<std::vector<PressureFrame>> pressure_frames_between(std::int64_t from_ns, std::int64_t to_ns);

  // Protocol actions (action_start .. action_end events) with the samples they span.
  Result<std::vector<ActionSpan>> actions();
  Result<std::vector<ProtocolEventRecord>> protocol_events();
  Result<std::vector<EventRecord>> events();
  Result<std::vector<OperatorNoteRecord>> operator_notes();
  Result<std::vector<CalibrationRecord>> calibrations();
  Result<std::vector<StreamStatistics>> stream_statistics();
  // Each camera's settings as recorded at its connection (devices.settings_json, docs/store.md), by name.
  Result<std::vector<std::pair<std::string, std::string>>> camera_settings();
  // Every frame of one device (camera or Sensel), by arrival.
  Result<std::vector<FrameTiming>> frame_timing(std::int64_t device_id);
  // Every pressure frame on the session clock as the device sent it, by connection and sequence.
  Result<std::vector<PressurePayload>> pressure_payloads();
  // Every pressure frame with a pressure image (connection 0), in order of its session-clock time.
  Result<std::vector<PressureTotal>> pressure_totals();
  // Every sample's references and offsets, in order (one query, for whole-session statistics).
  Result<std::vector<SampleInfo>> sample_infos();
  Result<std::vector<DropRecord>> drops();
  Result<std::vector<ClockModelRecord>> clock_models();
  // The timeline's tallies written at the end (what -> count), in the order written.
  Result<std::vector<std::pair<std::string, std::uint64_t>>> timeline_counts();

 private:
  SessionReader() = default;
  // `bayer_format`, when given, receives the video's Bayer pattern ("" for a colour video).
  // `region` (whole Bayer cells of the mosaic): that part of the mosaic alone (a tiled video decodes
  // only the tiles under it); nothing is checked against the frame's checksum.
  Result<cv::Mat> camera_image(const SampleCamera& c, bool mosaic = false, std::string* bayer_format = nullptr,
                               std::optional<cv::Rect> region = std::nullopt);
  Result<cv::Mat> one_image(std::size_t i, std::size_t camera, bool mosaic, std::string* bayer_format = nullptr,
                            std::optional<cv::Rect> region = std::nullopt);
  Demosaic demosaic_ = Demosaic::Bilinear;
  cv::Size image_size_;
  bool check_checksums_ = false;
  std::filesystem::path dir_;
  std::unique_ptr<sqlite::Database> db_;
  SessionInfo info_;
  std::vector<CameraInfo> cameras_;
  std::optional<PressureDeviceInfo> pressure_device_;
  std::vector<std::int64_t> sample_times_;  // t_ns by position (samples ordered by id)
  std::vector<std::uint64_t> sample_ids_;
  struct OpenVideo {
    std::int64_t device_id = 0;
    std::unique_ptr<VideoReader> reader;
  };
  std::map<std::int64_t, OpenVideo> videos_;  // by video file id, opened on use
  bool view_videos_ = false;
  ViewVideoReader views_{""};  // the session folder's, set at open()
};

}  // namespace pvcap
