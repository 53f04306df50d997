#include "storage/writer/session_writer.h"

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
#include "storage/index/index_queries.h"
#include "storage/index/video_repair.h"
#include "storage/video/camera_video_settings.h"
#include "storage/video/view_video.h"
#include "storage/video/view_video_writer.h"
#include "storage/writer/frame_spill.h"
#include "storage/writer/session_folder.h"
#include "storage/writer/session_writer_internal.h"

namespace pvcap {

namespace {
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
Status SessionWriter::open_segment(Camera& cam, std::int64_t first_pts_us, bool direct,
                                   std::vector<std::uint64_t> residual_counts) {
  const int segment = cam.segment + 1;
  const std::string file = fmt::format("{}-{:03}.mkv", safe_file_name(cam.name), segment);
  VideoSettings settings = cam.settings;
  settings.residual_counts = std::move(residual_counts);
  auto video = VideoWriter::open(dir_ / file, settings);
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
  cam->queue->share_halt(writes_halted_);
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
    writeback_ = std::thread([this] {
      name_this_thread("writeback");
      keep_written_back();
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

void SessionWriter::set_failure(std::string message, bool a_write_failed) {
  spdlog::error("{}", message);
  views_stopped_.store(true);
  if (a_write_failed) writes_halted_->store(true);
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
      set_failure(fmt::format("{}: the disk is nearly full ({} MB free, store.min_free_mb is {}): stopping so that "
                              "everything captured so far is kept",
                              dir_.string(), free / kMiB, store_.min_free_mb),
                  /*a_write_failed=*/false);
      return;
    }
  }
}

void SessionWriter::keep_durable() {
  // A round of fsyncs every interval, on the clock; a round that ends late starts the next at once.
  using Clock = std::chrono::steady_clock;
  const auto interval =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(store_.sync_interval_s));
  auto next_round = Clock::now() + interval;
  std::unique_lock lock(watch_mu_);
  while (!watch_cv_.wait_until(lock, next_round, [this] { return sync_stop_; })) {
    lock.unlock();
    next_round += interval;
    if (const auto now = Clock::now(); next_round < now) next_round = now;
    if (Status s = durable_->sync_changed(); !s.ok())
      set_failure(s.error().message);
    else
      say_if_slow(durable_->counts());
    lock.lock();
  }
}

void SessionWriter::keep_written_back() {
  // Between the rounds, steps of a quarter interval start the write-back of what changed. A step
  // can block on a congested disk (169 ms beside a test suite): on this thread it only delays the
  // next step, never a round.
  const auto step = std::chrono::duration<double>(store_.sync_interval_s / 4);
  std::unique_lock lock(watch_mu_);
  while (!watch_cv_.wait_for(lock, step, [this] { return sync_stop_; })) {
    lock.unlock();
    durable_->start_writeback();
    lock.lock();
  }
}

// A round of fsyncs longer than the interval stretches what a power cut can lose past the horizon
// docs/store.md promises: an event in the store (the report lists it) and a warning, every time.
// One slow round is one event: the gap the round after it measures (from the slow one's start)
// holds the same stall and is not said again.
void SessionWriter::say_if_slow(const DurableFolder::Counts& c) {
  const double limit_ms = std::max(1000.0, store_.sync_interval_s * 1000);
  const bool after_slow_round = previous_round_slow_;
  previous_round_slow_ = c.last_round_ms > limit_ms;
  std::string message;
  if (c.last_round_ms > limit_ms)
    message = fmt::format(
        "an fsync round of the session's files took {:.2f} s, longer than store.sync_interval_s ({:g} s): a power cut "
        "now could lose that much; the disk is too slow or too busy for the recording",
        c.last_round_ms / 1000, store_.sync_interval_s);
  else if (c.last_gap_ms > limit_ms && !after_slow_round)
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
    writes_halted_->store(true);
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

bool SessionWriter::writes_failed() const {
  if (writes_halted_->load()) return true;
  if (!index_writer_->failure()) return false;
  writes_halted_->store(true);
  return true;
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
  if (writeback_.joinable()) writeback_.join();
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
    checkpoint_index(index_->db());
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
