#include "storage/session_writer.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <type_traits>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "core/thread_name.h"
#include "core/time.h"
#include "storage/camera_video_settings.h"
#include "storage/frame_spill.h"
#include "storage/session_folder.h"
#include "storage/video_repair.h"
#include "storage/view_video.h"
#include "storage/view_video_writer.h"

namespace pvcap {

struct SessionWriter::Camera {
  std::int64_t device_id = 0;
  std::string name;
  VideoSettings settings;
  // The open segment (encoder thread only, after start()).
  std::unique_ptr<VideoWriter> video;
  std::int64_t video_file_id = 0;
  int segment = -1;
  std::int64_t segment_start_us = 0;
  std::vector<std::int64_t> failed_files;  // segments a write failed in: reconciled at close
  // The open segment's view video (storage/view_video.h), when store.view_videos.
  std::unique_ptr<ViewVideoWriter> view;
  std::unique_ptr<FrameSpillQueue> queue;  // made at add_camera, when the session folder exists
  std::thread thread;
  std::atomic<std::uint64_t> in_video{0}, encoder_drops{0}, segments{0};
  std::atomic<bool> failed{false};
};

namespace {
// How much nicer than the recorder's other threads an encoder runs (encode_loop).
constexpr int kEncoderNiceStep = 5;

std::int64_t free_bytes(const std::filesystem::path& dir) {
  struct statvfs st {};
  if (statvfs(dir.c_str(), &st) != 0) return -1;
  return std::int64_t(st.f_bavail) * std::int64_t(st.f_frsize);
}

constexpr std::int64_t kMiB = 1024 * 1024;

// A direct write to the index (before start(), on the caller's thread), with SQLite's exception
// turned into the Error this class returns: Status for writes, Result<T> for writes that give an id.
template <typename F>
auto index_write(F&& write) {
  using T = decltype(write());
  using Out = std::conditional_t<std::is_void_v<T>, Status, Result<T>>;
  try {
    if constexpr (std::is_void_v<T>) {
      write();
      return Out{};
    } else {
      return Out(write());
    }
  } catch (const sqlite::SqliteError& e) {
    return Out(Error{e.what()});
  }
}
}  // namespace

Result<std::unique_ptr<SessionWriter>> SessionWriter::create(const std::filesystem::path& root, const RigConfig& rig,
                                                             std::int64_t started_wall_ns, std::int64_t started_host_ns,
                                                             const WriterOptions& options) {
  std::error_code ec;
  std::filesystem::create_directories(root, ec);
  if (ec) return Error{fmt::format("{}: cannot create the sessions folder: {}", root.string(), ec.message())};
  const std::int64_t needed = std::int64_t(rig.store.min_free_mb + rig.store.reserve_mb) * kMiB;
  if (const std::int64_t free = free_bytes(root); free >= 0 && free < needed)
    return Error{
        fmt::format("{}: only {} MB free; a session needs at least {} MB to start (store.min_free_mb {} + "
                    "store.reserve_mb {})",
                    root.string(), free / kMiB, needed / kMiB, rig.store.min_free_mb, rig.store.reserve_mb)};
  auto made = make_session_folder(root, rig, started_wall_ns, started_host_ns);
  if (!made) return made.error();
  const std::filesystem::path dir = made.value();
  // Made only now: a writer that exists closes its session when it goes.
  std::unique_ptr<SessionWriter> w(new SessionWriter());
  w->dir_ = dir;
  w->started_host_ns_ = started_host_ns;
  w->store_ = rig.store;
  // A start that fails from here on leaves nothing behind: the folder is the one just made, and
  // holds only what this function put in it.
  auto abandon = [&w](Error e) -> Error {
    w->closed_ = true;  // nothing to finish
    if (w->lock_fd_ >= 0) ::close(w->lock_fd_);
    w->lock_fd_ = -1;
    w->index_.reset();
    std::error_code ignored;
    std::filesystem::remove_all(w->dir_, ignored);
    return e;
  };
  // Held until close(); the kernel drops it if the process dies, so a lock nobody holds means the
  // recording is over (pvcap recover checks it before touching anything).
  w->lock_fd_ = ::open((w->dir_ / kRecordingLock).c_str(), O_CREAT | O_WRONLY | O_CLOEXEC, 0644);
  if (w->lock_fd_ >= 0) flock(w->lock_fd_, LOCK_EX | LOCK_NB);
  if (rig.store.reserve_mb > 0) {
    // Real blocks, not a sparse file: this is the room close() needs when the disk fills.
    w->reserve_path_ = w->dir_ / "space-reserve";
    const int fd = ::open(w->reserve_path_.c_str(), O_CREAT | O_WRONLY | O_EXCL | O_CLOEXEC, 0644);
    const int rc = fd < 0 ? errno : posix_fallocate(fd, 0, off_t(rig.store.reserve_mb) * kMiB);
    if (fd >= 0) ::close(fd);
    if (rc != 0)
      return abandon(Error{fmt::format("{}: cannot set aside the {} MB space reserve: {}", w->reserve_path_.string(),
                                       rig.store.reserve_mb, std::strerror(rc))});
    w->reserve_held_.store(true);
  }
  try {
    w->index_.emplace(SessionIndex::open_for_update(w->dir_ / "session.db"));
  } catch (const sqlite::SqliteError& e) {
    return abandon(Error{e.what()});
  }
  w->encoder_frame_delay_ = options.encoder_frame_delay;
  w->encoder_stall_ = options.encoder_stall;
  w->view_backlog_frames_ = options.view_backlog_frames;
  w->index_writer_ = std::make_unique<IndexWriter>(
      *w->index_, options.index_queue_records, std::chrono::milliseconds(250), options.index_stall,
      w->dir_ / kSpillFolder / kIndexOverflowFile, options.index_overflow_memory_records, w->dir_ / kSpillFolder);
  return w;
}

SessionWriter::~SessionWriter() {
  if (!closed_) (void)close("aborted");
}

// Opens the camera's next segment. Before start() (`direct`) its row is written at once; after,
// through the index writer, ahead of the segment's frames.
Status SessionWriter::open_segment(Camera& cam, std::int64_t first_pts_us, bool direct) {
  const int segment = cam.segment + 1;
  const std::string file = fmt::format("{}-{:03}.mkv", safe_file_name(cam.name), segment);
  auto video = VideoWriter::open(dir_ / file, cam.settings);
  if (!video) return video.error();
  VideoFileRecord rec{next_video_file_id_.fetch_add(1),
                      cam.device_id,
                      file,
                      cam.settings.stored_codec(),
                      cam.settings.stored_pixel_format(),
                      cam.settings.width,
                      cam.settings.height,
                      segment};
  if (cam.settings.raw()) {
    rec.layout = cam.settings.layout;
    rec.bayer_format = cam.settings.bayer_format;
    rec.bit_depth = cam.settings.bit_depth;
  }
  if (direct) {
    if (Status s = index_write([&] { index_->add_video_file(rec); }); !s.ok()) return s;
  } else {
    index_writer_->push(rec);
  }
  cam.video = std::move(video.value());
  cam.video_file_id = rec.id;
  open_view(cam, file);
  cam.segment = segment;
  cam.segment_start_us = first_pts_us;
  cam.segments.fetch_add(1);
  return {};
}

Result<std::int64_t> SessionWriter::add_camera(const DeviceRecord& device, int width, int height,
                                               const std::string& pixel_format) {
  auto cam = std::make_unique<Camera>();
  cam->name = device.name;
  cam->queue = std::make_unique<FrameSpillQueue>(dir_, safe_file_name(device.name), std::size_t(store_.queue_frames));
  cam->settings = camera_video_settings(store_, width, height, pixel_format);
  cam->view = std::make_unique<ViewVideoWriter>(cam->name, cam->settings);
  auto id = index_write([&] { return index_->add_device(device); });
  if (!id) return id.error();
  cam->device_id = id.value();
  if (Status s = open_segment(*cam, 0, true); !s.ok()) return s.error();  // checks the codec settings now
  cameras_.push_back(std::move(cam));
  return id;
}

Result<std::int64_t> SessionWriter::add_device(const DeviceRecord& device) {
  return index_write([&] { return index_->add_device(device); });
}

Status SessionWriter::set_participant(const ParticipantRecord& p) {
  return index_write([&] { index_->set_participant(p); });
}

Status SessionWriter::set_conditions(const ConditionsRecord& c) {
  return index_write([&] { index_->set_conditions(c); });
}

Result<std::int64_t> SessionWriter::add_calibration(const CalibrationRecord& c) {
  return index_write([&] { return index_->add_calibration(c); });
}

void SessionWriter::start() {
  index_writer_->start();
  for (auto& cam : cameras_)
    cam->thread = std::thread([this, c = cam.get()] {
      name_this_thread("encode-" + c->name);
      encode_loop(*c);
    });
  watcher_ = std::thread([this] {
    name_this_thread("disk-space");
    watch_free_space();
  });
  if (store_.sync_interval_s > 0) {
    // The view copies too: a power cut must not leave a segment whose replay copy is seconds short.
    durable_ = std::make_unique<DurableFolder>(dir_, std::vector<std::string>{kSpillFolder, kViewFolder});
    syncer_ = std::thread([this] {
      name_this_thread("fsync");
      keep_durable();
    });
  }
}

bool SessionWriter::submit_video(std::int64_t device_id, cv::Mat bgr, FrameRecord frame) {
  for (auto& cam : cameras_) {
    if (cam->device_id != device_id) continue;
    if (cam->queue->push(std::move(bgr), std::move(frame))) return true;
    cam->encoder_drops.fetch_add(1);
    return false;
  }
  return false;
}

// The segment's view video, when the store keeps them and no storage failure has stopped them.
void SessionWriter::open_view(Camera& cam, const std::string& segment_file) {
  close_view(cam);
  if (store_.view_videos && !views_stopped_.load()) cam.view->open(dir_ / view_video_path(segment_file));
}

void SessionWriter::close_view(Camera& cam) {
  if (views_stopped_.load())
    cam.view->drop();
  else
    cam.view->close();
}

void SessionWriter::encode_loop(Camera& cam) {
  // The encoder is the one stage allowed to fall behind (its frames wait in the spill), so on a
  // busy machine it yields to the threads that may not: capture, the spill's writer, the index.
  // Nice only matters under contention; an idle machine encodes at full speed.
  const auto tid = id_t(syscall(SYS_gettid));
  errno = 0;
  const int nice_now = getpriority(PRIO_PROCESS, tid);
  const bool niced = errno == 0 && setpriority(PRIO_PROCESS, tid, std::min(19, nice_now + kEncoderNiceStep)) == 0;
  if (!niced) spdlog::debug("{}: encoder thread keeps the default priority ({})", cam.name, std::strerror(errno));
  const std::int64_t segment_us = std::int64_t(store_.segment_seconds * 1e6);
  FrameSpillQueue& queue = *cam.queue;
  std::optional<std::chrono::steady_clock::time_point> drain_started;
  auto next_progress = std::chrono::steady_clock::now();
  std::size_t drain_from = 0;
  bool drain_from_disk = false;
  std::optional<Stall> stall = encoder_stall_;  // a test's fault, once per encoder
  std::optional<std::chrono::steady_clock::time_point> first_frame;
  while (!queue.drained()) {
    // A test's stall, stall_after_s after the first frame, between two frames (as an encoder held up
    // by its disk): the frames come meanwhile go to the spill.
    if (stall && first_frame &&
        std::chrono::steady_clock::now() - *first_frame >= std::chrono::duration<double>(stall->after_s)) {
      spdlog::warn("{}: encoder stalled for {} s (PVCAP_FAULTS)", cam.name, stall->seconds);
      std::this_thread::sleep_for(std::chrono::duration<double>(stall->seconds));
      stall.reset();
    }
    auto item = queue.pop_for(std::chrono::milliseconds(100));
    if (item && !first_frame) first_frame = std::chrono::steady_clock::now();
    if (const auto now = std::chrono::steady_clock::now(); queue.is_closed() && now >= next_progress) {
      // The session has stopped and the encoder works through its backlog: a real drain (frames on
      // disk) is said, with progress; the few frames of the memory queue are not worth a line.
      const std::size_t left = queue.backlog(), on_disk = queue.on_disk();
      if (!drain_started) {
        drain_started = now;
        // Nothing is captured any more: the drain is what the operator waits for. (Taking the
        // priority back needs CAP_SYS_NICE or an rlimit; without them the drain stays nicer.)
        if (niced) (void)setpriority(PRIO_PROCESS, tid, nice_now);
        drain_from = left;
        drain_from_disk = on_disk > 0;
      }
      if (on_disk > 0)
        spdlog::info("{}: encoding the frames still waiting: {} left of {} ({} on disk)", cam.name, left, drain_from,
                     on_disk);
      next_progress = now + std::chrono::seconds(2);
    }
    if (!item) continue;
    if (!item->lost_reason.empty()) {  // the spill could not take it: recorded with why
      cam.encoder_drops.fetch_add(1);
      item->rec.reason = item->lost_reason;
      index_writer_->push(std::move(item->rec));
      continue;
    }
    cv::Mat& bgr = item->image;
    FrameRecord& rec = item->rec;
    // The frame's instant on the session clock when the timeline mapped it (evenly spaced, as the
    // camera exposed them), else its arrival; the file's exact timestamp goes into its row.
    const std::int64_t pts_us = (rec.mapped_ns.value_or(rec.host_ns) - started_host_ns_) / 1000;
    if (!cam.failed.load() && segment_us > 0 && cam.video->frames_written() > 0 &&
        pts_us - cam.segment_start_us >= segment_us) {
      // Next segment: the finished one gets its trailer (cues, duration) and is final on disk.
      const std::int64_t id = cam.video_file_id, frames = cam.video->frames_written();
      close_view(cam);
      if (Status s = cam.video->close(); !s.ok()) {
        cam.failed_files.push_back(id);
        cam.failed.store(true);
        set_failure(s.error().message);
      } else {
        index_writer_->push(VideoFileClosed{id, frames});
        queue.release_finished();  // spilled frames in the finished segment are safe on disk now
        if (Status o = open_segment(cam, pts_us, false); !o.ok()) {
          cam.failed.store(true);
          set_failure(o.error().message);
        }
      }
    }
    if (!cam.failed.load()) {
      if (encoder_frame_delay_.count() > 0) std::this_thread::sleep_for(encoder_frame_delay_);  // a test's fault
      auto index = cam.video->write(bgr, pts_us);
      if (index) {
        rec.kept = true;
        rec.video_file_id = cam.video_file_id;
        rec.video_index = index.value();
        rec.video_pts_ms = cam.video->last_pts_ms();
        cam.in_video.fetch_add(1);
        // The view copy only while the encoder keeps up: on a busy machine it is the first work to
        // go, before any frame has to wait on disk (the replay reads those frames losslessly).
        if (views_stopped_.load()) cam.view->drop();
        if (queue.backlog() <= view_backlog_frames_) cam.view->write(bgr, *cam.video, pts_us);
      } else {
        cam.failed_files.push_back(cam.video_file_id);
        cam.failed.store(true);
        set_failure(index.error().message);
      }
    }
    if (!rec.kept) rec.reason = "video_write_failed";
    queue.written(*item);  // out of memory now (its bytes are in its video, or it failed with the file)
    index_writer_->push(std::move(rec));
  }
  close_view(cam);
  const double drain_s =
      drain_started ? std::chrono::duration<double>(std::chrono::steady_clock::now() - *drain_started).count() : 0;
  if (drain_from_disk)
    spdlog::info("{}: {} waiting frames encoded in {:.1f} s after the stop", cam.name, drain_from, drain_s);
  record_disk_age(cam);
  // The spill in the store: how many frames waited on disk, and how long the end waited for them.
  if (const std::uint64_t spilled = queue.spilled_total(); spilled > 0)
    index_writer_->push(EventRecord{host_now().ns, "spill", cam.device_id,
                                    fmt::format("{} frames waited on disk for the encoder (the spill); {} frames were "
                                                "still waiting at the stop, encoded in {:.1f} s",
                                                spilled, drain_from, drain_s)});
}

// How long a kept frame could wait in memory before its bytes reached the kernel: with the sync
// interval, what a power cut can take (docs/store.md promises a second). An event, and a warning
// when together they pass a second.
void SessionWriter::record_disk_age(const Camera& cam) {
  const auto age = cam.queue->worst_disk_age();
  if (age.worst_ns <= 0) return;
  const std::string said = fmt::format(
      "{}: its kept frames reached the disk's files at most {:.0f} ms after they arrived (the worst arrived {:.1f} s "
      "into the session, and went to {})",
      cam.name, double(age.worst_ns) / 1e6, double(age.arrived_host_ns - started_host_ns_) / 1e9,
      age.via_spill ? "the spill" : "its video");
  const double sync_s = store_.sync_interval_s;
  if (sync_s > 0 && double(age.worst_ns) / 1e9 + sync_s > 1.0)
    spdlog::warn("{}; with a sync every {} s, a power cut then could have taken more than a second of it", said,
                 sync_s);
  else
    spdlog::debug("{}", said);
  index_writer_->push(EventRecord{host_now().ns, "disk_age", cam.device_id, said});
}

void SessionWriter::set_failure(std::string message) {
  spdlog::error("{}", message);
  views_stopped_.store(true);
  release_reserve();  // whatever failed, close() must be able to finish what is captured
  std::lock_guard lock(failure_mu_);
  if (!failure_) failure_ = std::move(message);
}

void SessionWriter::release_reserve() const {
  if (!reserve_held_.exchange(false)) return;
  std::error_code ec;
  std::filesystem::remove(reserve_path_, ec);
}

void SessionWriter::watch_free_space() {
  const std::int64_t min_free = std::int64_t(store_.min_free_mb) * kMiB;
  std::unique_lock lock(watch_mu_);
  while (!watch_cv_.wait_for(lock, std::chrono::milliseconds(250), [this] { return watch_stop_; })) {
    const std::int64_t free = free_bytes(dir_);
    if (free >= 0 && free < min_free) {
      set_failure(
          fmt::format("{}: the disk is nearly full ({} MB free, store.min_free_mb is {}): stopping so that "
                      "everything captured so far is kept",
                      dir_.string(), free / kMiB, store_.min_free_mb));
      return;
    }
  }
}

void SessionWriter::keep_durable() {
  // A round of fsyncs every interval, on the clock: between rounds, steps of a quarter interval start
  // the write-back of what changed, while time is left (a write-back step can block on a congested
  // disk; it must not push the round later). A round that ends late starts the next at once.
  using Clock = std::chrono::steady_clock;
  const auto interval =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(store_.sync_interval_s));
  const auto step = interval / 4;
  auto next_round = Clock::now() + interval;
  std::unique_lock lock(watch_mu_);
  while (!watch_cv_.wait_until(lock, std::min(next_round, Clock::now() + step), [this] { return sync_stop_; })) {
    lock.unlock();
    const auto now = Clock::now();
    if (now + step / 2 < next_round) {
      durable_->start_writeback();
    } else {
      next_round += interval;
      if (next_round < now) next_round = now;
      if (Status s = durable_->sync_changed(); !s.ok())
        set_failure(s.error().message);
      else
        say_if_slow(durable_->counts());
    }
    lock.lock();
  }
}

// A round of fsyncs longer than the interval stretches what a power cut can lose past the horizon
// docs/store.md promises: an event in the store (the report lists it) and a warning, every time.
void SessionWriter::say_if_slow(const DurableFolder::Counts& c) {
  const double limit_ms = std::max(1000.0, store_.sync_interval_s * 1000);
  std::string message;
  if (c.last_round_ms > limit_ms)
    message = fmt::format(
        "an fsync round of the session's files took {:.2f} s, longer than store.sync_interval_s ({:g} s): a power cut "
        "now could lose that much; the disk is too slow or too busy for the recording",
        c.last_round_ms / 1000, store_.sync_interval_s);
  else if (c.last_gap_ms > limit_ms)
    message = fmt::format(
        "the session's files went {:.2f} s between two fsync rounds (store.sync_interval_s: {:g} s): a power cut "
        "now could lose that much; the disk or the machine is too busy for the recording",
        c.last_gap_ms / 1000, store_.sync_interval_s);
  if (message.empty()) return;
  spdlog::warn("{}: {}", dir_.string(), message);
  record(EventRecord{host_now().ns, "fsync_slow", std::nullopt, message});
}

std::optional<std::string> SessionWriter::failure() const {
  if (auto f = index_writer_->failure()) {
    release_reserve();  // the index's own failure: close() will need the room
    return f;
  }
  std::lock_guard lock(failure_mu_);
  if (failure_) return failure_;
  // A spill the disk refused (an I/O error, not a slow encoder): the store cannot keep what comes,
  // so capture stops, as for any failed write.
  for (const auto& cam : cameras_)
    if (auto f = cam->queue->failure()) return fmt::format("{}: the spill to disk failed: {}", cam->name, *f);
  return std::nullopt;
}

const SessionWriter::Camera* SessionWriter::camera(std::int64_t device_id) const {
  for (const auto& cam : cameras_)
    if (cam->device_id == device_id) return cam.get();
  return nullptr;
}

PlaneOrder SessionWriter::raw_plane_order(std::int64_t device_id) const {
  if (const Camera* cam = camera(device_id); cam && cam->settings.raw())
    if (auto order = plane_order(cam->settings.layout, cam->settings.bayer_format)) return order.value();
  return kCellOrder;
}

bool SessionWriter::stores_raw(std::int64_t device_id) const {
  const Camera* cam = camera(device_id);
  return cam && cam->settings.raw();
}

CameraStoreStats SessionWriter::camera_stats(std::int64_t device_id) const {
  const Camera* cam = camera(device_id);
  if (!cam) return {};
  return {cam->in_video.load(),  cam->encoder_drops.load(), cam->segments.load(),
          cam->queue->backlog(), cam->queue->on_disk(),     cam->queue->spilled_total()};
}

Status SessionWriter::close(const std::string& end_reason) {
  if (closed_) return {};
  closed_ = true;
  Status result;
  {
    std::lock_guard lock(watch_mu_);
    watch_stop_ = true;
  }
  watch_cv_.notify_all();
  if (watcher_.joinable()) watcher_.join();
  const bool storage_failed = failure().has_value();
  if (storage_failed) release_reserve();
  for (auto& cam : cameras_) cam->queue->close();
  for (auto& cam : cameras_) {
    if (cam->thread.joinable()) cam->thread.join();
    // A view copy the disk failed: the camera's own video is whole, but the disk is failing.
    if (const auto& why = cam->view->failure(); why && !views_stopped_.load() && result.ok())
      result =
          Error{fmt::format("{}: a view video failed ({}); the camera's own video is complete, but the disk "
                            "may be failing",
                            cam->name, *why)};
    if (!cam->failed.load()) {
      const std::int64_t frames = cam->video->frames_written();
      if (Status s = cam->video->close(); !s.ok()) {
        cam->failed_files.push_back(cam->video_file_id);
        if (result.ok()) result = s;
      } else {
        index_writer_->push(VideoFileClosed{cam->video_file_id, frames});
        cam->queue->release_finished();
      }
    } else {
      (void)cam->video->close();  // best effort: its tail may be cut; reconciled below
    }
  }
  index_writer_->stop();
  if (const auto f = index_writer_->side_failure(); f && result.ok() && !storage_failed)
    result =
        Error{fmt::format("the index's journal of rows not yet committed failed ({}); the index itself is "
                          "complete, but the disk may be failing",
                          *f)};
  {
    // Empty once every spill is encoded and released and the index holds every row (the journal's
    // files gone); else kept for recover.
    std::error_code ec;
    std::filesystem::remove(dir_ / kSpillFolder, ec);
  }
  if (auto f = index_writer_->failure(); f && result.ok()) result = Error{*f};
  {
    std::lock_guard lock(watch_mu_);
    sync_stop_ = true;
  }
  watch_cv_.notify_all();
  if (syncer_.joinable()) syncer_.join();
  if (auto f = failure(); f && result.ok()) result = Error{*f};  // the writer's own, or a spill's
  std::lock_guard lock(failure_mu_);
  // A segment whose writing failed holds fewer frames than were handed to it: the index is made
  // to say so, frame by frame, from what the file really holds.
  for (auto& cam : cameras_)
    for (const std::int64_t id : cam->failed_files) {
      try {
        const auto r = reconcile_video_file(*index_, dir_, id, "video_write_failed", "failed");
        spdlog::warn("{}: {} frames readable; {} indexed frames after them were not written", r.path, r.frames_in_file,
                     r.rows_marked_lost);
      } catch (const std::exception& e) {
        if (result.ok()) result = Error{fmt::format("{}: {}", dir_.string(), e.what())};
      }
    }
  if (finalizer_ && !storage_failed) {
    try {
      finalizer_(*index_);  // commits its own steps
    } catch (const std::exception& e) {
      // The store keeps the online timeline; recover finds the re-mapping unfinished and does it.
      if (result.ok())
        result =
            Error{fmt::format("{}: re-mapping the timeline at the end failed ({}); the online values stay, and "
                              "`pvcap recover {}` tries again",
                              dir_.string(), e.what(), dir_.string())};
    }
  }
  try {
    sqlite::Transaction tx(index_->db());
    for (const auto& s : stream_stats_) index_->add_stream_stats(s);
    for (const auto& [what, count] : timeline_counts_) index_->add_timeline_count(what, count);
    index_->finish_session(host_now().ns, end_reason);
    tx.commit();
    index_->db().exec("PRAGMA wal_checkpoint(TRUNCATE)");
  } catch (const sqlite::SqliteError& e) {
    if (result.ok()) result = Error{e.what()};
  }
  release_reserve();
  if (lock_fd_ >= 0) {
    std::error_code ec;
    std::filesystem::remove(dir_ / kRecordingLock, ec);
    ::close(lock_fd_);
    lock_fd_ = -1;
  }
  if (durable_) {  // the finished store, its last rows and the lock's removal, on stable storage
    if (Status s = durable_->sync_changed(); !s.ok() && result.ok()) result = s;
    const auto& c = durable_->counts();
    spdlog::debug("{}: {} fsync rounds, {} file and {} folder syncs, the slowest round {:.1f} ms", dir_.string(),
                  c.rounds, c.file_syncs, c.folder_syncs, c.slowest_round_ms);
  }
  return result;
}

}  // namespace pvcap
