#pragma once
// The writing side of a session store: one new directory per session holding
// session.db (the index) and one video per camera. Facade over the index,
// its writer thread and one encoder thread per camera.
//
// Life cycle: create() -> add_camera() for each camera -> start() -> record_*()
// and submit_video() from the capture pipeline (never waits) -> close().
// A session directory is never reused: create() fails rather than overwrite.
#include <atomic>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include "core/bounded_queue.h"
#include "core/result.h"
#include "core/rig_config.h"
#include "storage/index_writer.h"
#include "storage/session_index.h"
#include "storage/video_writer.h"

namespace pvcap {

struct CameraStoreStats {
  std::uint64_t frames_in_video = 0;
  std::uint64_t encoder_drops = 0;   // kept frames the encoder could not take in time
};

class SessionWriter {
 public:
  // Makes `<root>/<UTC date-time>_<rig name>` (suffixing -2, -3... if taken).
  static Result<std::unique_ptr<SessionWriter>> create(const std::filesystem::path& root, const RigConfig& rig,
                                                       std::int64_t started_wall_ns, std::int64_t started_host_ns);
  ~SessionWriter();

  // Registers a camera and its video; returns its device id in the index.
  Result<std::int64_t> add_camera(const DeviceRecord& device, int width, int height);
  void start();

  // Index records (any thread, never waits).
  void record(FrameRecord frame) { index_writer_->push(std::move(frame)); }
  void record(DropRecord drop) { index_writer_->push(std::move(drop)); }
  void record(PressureRecord pressure) { index_writer_->push(std::move(pressure)); }
  // Registers a non-video device (the Sensel); returns its device id.
  Result<std::int64_t> add_device(const DeviceRecord& device);
  void record(EventRecord event) { index_writer_->push(std::move(event)); }
  void record(SampleRecord sample) { index_writer_->push(std::move(sample)); }
  void record(ClockModelRecord clock) { index_writer_->push(std::move(clock)); }
  // Written at close (the timeline's tallies: groups, missed ticks, unpaired samples by reason).
  void add_timeline_count(std::string what, std::uint64_t count) { timeline_counts_.emplace_back(std::move(what), count); }
  // Queues a kept frame for its camera's video. False (and nothing queued) when the
  // encoder is behind; the caller records the frame as not kept, reason "encoder_behind".
  bool submit_video(std::int64_t device_id, cv::Mat bgr, FrameRecord frame);

  void add_stream_stats(const StreamStatsRecord& stats) { stream_stats_.push_back(stats); }
  // Set when storage failed (disk full, encoder error): capture should stop.
  std::optional<std::string> failure() const;

  // Runs on the finished index at close, before the session is marked ended, in its own
  // transaction (the timeline's final re-mapping). A failure is reported, and leaves the
  // values recorded online in place.
  void set_finalizer(std::function<void(SessionIndex&)> finalize) { finalizer_ = std::move(finalize); }
  // Drains every queue, finishes videos and index. Returns the first error, if any.
  Status close(const std::string& end_reason);

  const std::filesystem::path& dir() const { return dir_; }
  CameraStoreStats camera_stats(std::int64_t device_id) const;
  std::uint64_t index_records_lost() const { return index_writer_->records_lost(); }

 private:
  SessionWriter() = default;
  struct Camera;
  void encode_loop(Camera& cam);

  std::filesystem::path dir_;
  std::int64_t started_host_ns_ = 0;
  StoreConfig store_;
  std::optional<SessionIndex> index_;
  std::unique_ptr<IndexWriter> index_writer_;
  std::vector<std::unique_ptr<Camera>> cameras_;
  std::vector<StreamStatsRecord> stream_stats_;
  std::vector<std::pair<std::string, std::uint64_t>> timeline_counts_;
  std::function<void(SessionIndex&)> finalizer_;
  bool closed_ = false;
};

}  // namespace pvcap
