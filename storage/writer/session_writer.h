#pragma once
// The writing side of a session store: one new directory per session holding
// session.db (the index) and each camera's video in segments. Facade over the
// index, its writer thread and one encoder thread per camera.
//
// Life cycle: create() -> add_camera() for each camera, set_participant() etc.
// -> start() -> record_*() and submit_video() from the capture pipeline (never
// waits) -> close(). A session directory is never reused: create() fails rather
// than overwrite.
//
// Running out of disk: a watcher stops the session (failure()) when free space
// drops below store.min_free_mb; if the disk fills anyway, the space reserve
// (store.reserve_mb, a file made at create()) is freed so that close() can still
// finish every video and the index, and what made it to disk stays readable.
#include <atomic>
#include <condition_variable>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include "core/bounded_queue.h"
#include "core/durable_folder.h"
#include "core/result.h"
#include "core/rig_config.h"
#include "storage/index/session_index.h"
#include "storage/video/video_writer.h"
#include "storage/writer/index_writer.h"
#include "storage/writer/recording_store.h"

namespace pvcap {

// How the writer's threads run: the index queue's size, and a test's faults (core/fault_injection.h).
struct WriterOptions {
  std::size_t index_queue_records = IndexWriter::kQueueRecords;
  std::size_t index_overflow_memory_records = IndexOverflow::kMemoryRecords;  // then on disk
  std::optional<Stall> index_stall;
  // Each encoder waits this long before every frame: an encoder slower than its camera on any
  // machine, so the spill is exercised deterministically rather than by a slow codec preset.
  std::chrono::milliseconds encoder_frame_delay{0};
  // Each encoder sleeps once (a disk that held the encoders up): the spill takes their frames.
  std::optional<Stall> encoder_stall;
  // An encoder with more of its camera's frames waiting than this skips their view copies
  // (storage/video/view_video.h): on a busy machine they are the first work to go.
  std::size_t view_backlog_frames = 2;
};

class SessionWriter : public RecordingStore {
 public:
  // Makes `<root>/<UTC date-time>_<rig name>` (suffixing -2, -3... if taken).
  static Result<std::unique_ptr<SessionWriter>> create(const std::filesystem::path& root, const RigConfig& rig,
                                                       std::int64_t started_wall_ns, std::int64_t started_host_ns,
                                                       const WriterOptions& options = {});
  ~SessionWriter() override;

  // Registers a camera and opens its first video segment; returns its device id in the index.
  // `pixel_format` is what the camera sends (PFNC name): a Bayer mosaic is stored raw when
  // store.video_mode is raw (submit_video then takes the mosaic), anything else in colour.
  Result<std::int64_t> add_camera(const DeviceRecord& device, int width, int height,
                                  const std::string& pixel_format = "") override;
  // Whether this camera's video takes the sensor's mosaic (CV_8UC1) rather than BGR images.
  bool stores_raw(std::int64_t device_id) const override;
  // How its raw video stacks the mosaic's planes: the order its capture checksums run over.
  PlaneOrder raw_plane_order(std::int64_t device_id) const override;
  // Registers a non-video device (the Sensel); returns its device id.
  Result<std::int64_t> add_device(const DeviceRecord& device) override;
  // Session conditions and calibrations, written before start().
  Status set_participant(const ParticipantRecord& p) override;
  Status set_conditions(const ConditionsRecord& c) override;
  Result<std::int64_t> add_calibration(const CalibrationRecord& c) override;
  void start() override;

  // Index records (any thread, never waits).
  void record(FrameRecord frame) override { index_writer_->push(std::move(frame)); }
  void record(DropRecord drop) override { index_writer_->push(std::move(drop)); }
  void record(PressureRecord pressure) override { index_writer_->push(std::move(pressure)); }
  void record(EventRecord event) override { index_writer_->push(std::move(event)); }
  void record(SampleRecord sample) override { index_writer_->push(std::move(sample)); }
  void record(ClockModelRecord clock) override { index_writer_->push(std::move(clock)); }
  void record(ProtocolEventRecord event) override { index_writer_->push(std::move(event)); }
  void record(OperatorNoteRecord note) override { index_writer_->push(std::move(note)); }
  // Records and waits until committed (at most `timeout`): protocol transitions are on disk before
  // they are acknowledged. False when not committed in time or the index failed.
  bool record_committed(ProtocolEventRecord event, std::chrono::milliseconds timeout) override {
    return index_writer_->push_committed(std::move(event), timeout);
  }
  bool record_committed(OperatorNoteRecord note, std::chrono::milliseconds timeout) override {
    return index_writer_->push_committed(std::move(note), timeout);
  }
  // Written at close (the timeline's tallies: groups, missed ticks, unpaired samples by reason).
  void add_timeline_count(std::string what, std::uint64_t count) override {
    timeline_counts_.emplace_back(std::move(what), count);
  }
  // Queues a kept frame (BGR, or the mosaic when stores_raw) for its camera's video: in memory, or
  // through the camera's spill on disk when the encoder is behind (storage/writer/frame_spill.h). False
  // (nothing queued) only when the spill cannot keep up either, or the disk refused it; the caller
  // records the frame as not kept, reason "encoder_behind" ("storage_failed" once writes_failed()).
  bool submit_video(std::int64_t device_id, cv::Mat bgr, FrameRecord frame) override;
  // The disk refused a write of this session (a video, the index, a spill, an fsync): nothing more
  // is written: the encoders stop, so that the reserve finishes the index, and their queues refuse.
  bool writes_failed() const override;

  void add_stream_stats(const StreamStatsRecord& stats) override { stream_stats_.push_back(stats); }
  // Set when storage failed or the disk is nearly full: capture should stop.
  std::optional<std::string> failure() const override;

  // Runs on the finished index at close, before the session is marked ended (the timeline's
  // final re-mapping); it commits its own transactions. A failure is reported, and leaves the
  // values recorded online (or its committed steps) in place.
  void set_finalizer(std::function<void(SessionIndex&)> finalize) override { finalizer_ = std::move(finalize); }
  // Drains every queue (a spill to its end, with progress in the log), finishes videos and index.
  // Returns the first error, if any.
  Status close(const std::string& end_reason) override;

  const std::filesystem::path& dir() const override { return dir_; }
  CameraStoreStats camera_stats(std::int64_t device_id) const override;
  std::uint64_t index_records_lost() const override { return index_writer_->records_lost(); }
  std::uint64_t index_records_waited() const override { return index_writer_->records_waited(); }
  std::string index_records_lost_by_kind() const override { return index_writer_->lost_records_by_kind(); }

 private:
  SessionWriter() = default;
  struct Camera;
  void encode_loop(Camera& cam);
  void record_disk_age(const Camera& cam);
  void open_view(Camera& cam, const std::string& segment_file);
  void close_view(Camera& cam);
  // `residual_counts`: a raw HuffYUV segment's tables fitted to them (VideoSettings::residual_counts).
  Status open_segment(Camera& cam, std::int64_t first_pts_us, bool direct,
                      std::vector<std::uint64_t> residual_counts = {});
  // `a_write_failed`: the disk refused a write (else a stop before one would: the free-space watch).
  void set_failure(std::string message, bool a_write_failed = true);
  void abandon_backlog(Camera& cam);
  void watch_free_space();
  void keep_durable();       // the fsync rounds' thread
  void keep_written_back();  // the write-back steps' thread, between the rounds
  void say_if_slow(const DurableFolder::Counts& counts);
  void release_reserve() const;  // idempotent; any thread

  std::filesystem::path dir_;
  std::int64_t started_host_ns_ = 0;
  std::chrono::milliseconds encoder_frame_delay_{0};
  std::optional<Stall> encoder_stall_;
  std::size_t view_backlog_frames_ = 2;
  StoreConfig store_;
  std::optional<SessionIndex> index_;
  std::unique_ptr<IndexWriter> index_writer_;
  std::vector<std::unique_ptr<Camera>> cameras_;
  const Camera* camera(std::int64_t device_id) const;  // nullptr: not one of this session's cameras
  std::atomic<std::int64_t> next_video_file_id_{1};
  std::vector<StreamStatsRecord> stream_stats_;
  std::vector<std::pair<std::string, std::uint64_t>> timeline_counts_;
  std::function<void(SessionIndex&)> finalizer_;
  bool closed_ = false;

  int lock_fd_ = -1;  // flock on <dir>/recording.lock while recording: recover refuses a live session
  std::filesystem::path reserve_path_;
  mutable std::atomic<bool> reserve_held_{false};
  // Set with the first failure: the view videos stop and their open files go, so what space is left
  // finishes the lossless videos and the index.
  std::atomic<bool> views_stopped_{false};
  // Set when the disk refuses any of the session's writes (the writer's own, a spill's at once, the
  // index's when failure() sees it): from then on nothing more is written.
  std::shared_ptr<std::atomic<bool>> writes_halted_ = std::make_shared<std::atomic<bool>>(false);
  mutable std::mutex failure_mu_;
  std::optional<std::string> failure_;  // the writer's own (video, free space); the index's is its own
  std::thread watcher_;
  std::mutex watch_mu_;
  std::condition_variable watch_cv_;
  bool watch_stop_ = false;
  // The durability horizon: every changed file fsynced each store.sync_interval_s, on its own
  // thread (an fsync may take a while; the free-space watch must not wait for it).
  std::unique_ptr<DurableFolder> durable_;
  std::thread syncer_, writeback_;
  bool previous_round_slow_ = false;  // the fsync thread's: its last round was said to be slow
  bool sync_stop_ = false;
};

}  // namespace pvcap
