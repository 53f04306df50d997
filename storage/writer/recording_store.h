#pragma once
// What a recording writes into, as the recording sees it: devices registered before start(), index
// records from any thread (never waiting), kept frames for the videos, failures to stop on, and
// close(). SessionWriter (storage/writer/session_writer.h) is the store's; a test gives a recording
// one of its own (tests/unit/session/test_recording.cpp), as rosbag2 tests its recorder through its
// writer interface.
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "core/result.h"
#include "storage/index/records.h"
#include "storage/video/bayer_planes.h"

namespace pvcap {

class SessionIndex;

struct CameraStoreStats {
  std::uint64_t frames_in_video = 0;
  std::uint64_t encoder_drops = 0;  // kept frames neither the encoder nor its spill could take
  std::uint64_t segments = 0;
  std::size_t encoder_backlog = 0;  // kept frames waiting for the encoder now (memory and spill)
  std::size_t spill_backlog = 0;    // of which on disk
  std::uint64_t spilled = 0;        // frames that went through the spill so far
};

class RecordingStore {
 public:
  virtual ~RecordingStore() = default;

  // Before start(): the devices (each camera's video opened; returns its device id), the session's
  // participant, conditions and calibrations.
  virtual Result<std::int64_t> add_camera(const DeviceRecord& device, int width, int height,
                                          const std::string& pixel_format) = 0;
  virtual bool stores_raw(std::int64_t device_id) const = 0;  // its video takes the mosaic (CV_8UC1)
  virtual PlaneOrder raw_plane_order(std::int64_t device_id) const = 0;
  virtual Result<std::int64_t> add_device(const DeviceRecord& device) = 0;
  virtual Status set_participant(const ParticipantRecord& p) = 0;
  virtual Status set_conditions(const ConditionsRecord& c) = 0;
  virtual Result<std::int64_t> add_calibration(const CalibrationRecord& c) = 0;
  virtual void start() = 0;

  // Index records (any thread, never waits).
  virtual void record(FrameRecord frame) = 0;
  virtual void record(DropRecord drop) = 0;
  virtual void record(PressureRecord pressure) = 0;
  virtual void record(EventRecord event) = 0;
  virtual void record(SampleRecord sample) = 0;
  virtual void record(ClockModelRecord clock) = 0;
  virtual void record(ProtocolEventRecord event) = 0;
  virtual void record(OperatorNoteRecord note) = 0;
  // Records and waits until committed (at most `timeout`); false when it was not.
  virtual bool record_committed(ProtocolEventRecord event, std::chrono::milliseconds timeout) = 0;
  virtual bool record_committed(OperatorNoteRecord note, std::chrono::milliseconds timeout) = 0;
  virtual void add_timeline_count(std::string what, std::uint64_t count) = 0;  // written at close
  // A kept frame for its camera's video; false when it could not be queued (the frame is not kept).
  virtual bool submit_video(std::int64_t device_id, cv::Mat image, FrameRecord frame) = 0;
  virtual bool writes_failed() const = 0;  // the disk refused a write: nothing more is written
  virtual void add_stream_stats(const StreamStatsRecord& stats) = 0;
  // Set when the store failed or the disk is nearly full: the recording stops.
  virtual std::optional<std::string> failure() const = 0;

  // Runs on the finished index at close, before the session is marked ended.
  virtual void set_finalizer(std::function<void(SessionIndex&)> finalize) = 0;
  // Drains every queue and finishes the store; the first error, if any.
  virtual Status close(const std::string& end_reason) = 0;

  virtual const std::filesystem::path& dir() const = 0;
  virtual CameraStoreStats camera_stats(std::int64_t device_id) const = 0;
  virtual std::uint64_t index_records_lost() const = 0;
  virtual std::uint64_t index_records_waited() const = 0;
  virtual std::string index_records_lost_by_kind() const = 0;
};

}  // namespace pvcap
