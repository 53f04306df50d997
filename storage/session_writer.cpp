#include "storage/session_writer.h"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "core/time.h"
#include "core/version.h"

namespace pvcap {

struct SessionWriter::Camera {
  std::int64_t device_id = 0;
  std::int64_t video_file_id = 0;
  std::string name;
  std::unique_ptr<VideoWriter> video;
  BoundedQueue<std::pair<cv::Mat, FrameRecord>> queue;
  std::thread thread;
  std::atomic<std::uint64_t> indexed{0}, in_video{0}, encoder_drops{0};
  mutable std::mutex failure_mu;
  std::optional<std::string> failure;
  explicit Camera(std::size_t capacity) : queue(capacity) {}
};

namespace {
std::string safe_name(std::string s) {
  for (char& c : s)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '-';
  return s;
}
}  // namespace

Result<std::unique_ptr<SessionWriter>> SessionWriter::create(const std::filesystem::path& root, const RigConfig& rig,
                                                             std::int64_t started_wall_ns,
                                                             std::int64_t started_host_ns) {
  std::error_code ec;
  std::filesystem::create_directories(root, ec);
  if (ec) return Error{fmt::format("{}: cannot create the sessions folder: {}", root.string(), ec.message())};
  std::unique_ptr<SessionWriter> w(new SessionWriter());
  const std::string base = format_utc_compact(started_wall_ns) + "_" + safe_name(rig.name);
  for (int n = 1;; ++n) {
    const auto candidate = root / (n == 1 ? base : fmt::format("{}-{}", base, n));
    if (mkdir(candidate.c_str(), 0775) == 0) {  // atomic: never reuses an existing session
      w->dir_ = candidate;
      break;
    }
    if (errno != EEXIST || n > 999)
      return Error{fmt::format("{}: cannot create the session folder: {}", candidate.string(), std::strerror(errno))};
  }
  w->started_host_ns_ = started_host_ns;
  w->store_ = rig.store;
  try {
    w->index_.emplace(SessionIndex::create(w->dir_ / "session.db"));
    SessionRecord s{started_wall_ns, started_host_ns, kVersion, rig.name, rig.source.string(), rig.text,
                    rig.sim.has_value()};
    w->index_->add_session(s);
  } catch (const sqlite::SqliteError& e) {
    return Error{e.what()};
  }
  w->index_writer_ = std::make_unique<IndexWriter>(*w->index_);
  return w;
}

SessionWriter::~SessionWriter() {
  if (!closed_) (void)close("aborted");
}

Result<std::int64_t> SessionWriter::add_camera(const DeviceRecord& device, int width, int height) {
  auto cam = std::make_unique<Camera>(std::size_t(store_.queue_frames));
  cam->name = device.name;
  const std::string file = safe_name(device.name) + ".mkv";
  VideoSettings vs;
  vs.codec = store_.video_codec;
  vs.crf = store_.crf;
  vs.preset = store_.preset;
  vs.pixel_format = store_.video_pixel_format;
  vs.width = width;
  vs.height = height;
  vs.nominal_fps = store_.video_fps > 0 ? store_.video_fps : 30;
  vs.gop_frames = std::max(1, int(vs.nominal_fps * store_.gop_seconds_x10 / 10.0));
  auto video = VideoWriter::open(dir_ / file, vs);
  if (!video) return video.error();
  cam->video = std::move(video.value());
  try {
    cam->device_id = index_->add_device(device);
    cam->video_file_id =
        index_->add_video_file({cam->device_id, file, vs.codec, vs.pixel_format, width, height});
  } catch (const sqlite::SqliteError& e) {
    return Error{e.what()};
  }
  const std::int64_t id = cam->device_id;
  cameras_.push_back(std::move(cam));
  return id;
}

Result<std::int64_t> SessionWriter::add_device(const DeviceRecord& device) {
  try {
    return index_->add_device(device);
  } catch (const sqlite::SqliteError& e) {
    return Error{e.what()};
  }
}

void SessionWriter::start() {
  index_writer_->start();
  for (auto& cam : cameras_) cam->thread = std::thread([this, c = cam.get()] { encode_loop(*c); });
}

bool SessionWriter::submit_video(std::int64_t device_id, cv::Mat bgr, FrameRecord frame) {
  for (auto& cam : cameras_) {
    if (cam->device_id != device_id) continue;
    std::pair<cv::Mat, FrameRecord> item{std::move(bgr), std::move(frame)};
    if (cam->queue.try_push(item)) return true;
    cam->encoder_drops.fetch_add(1);
    return false;
  }
  return false;
}

void SessionWriter::encode_loop(Camera& cam) {
  while (!cam.queue.closed_and_empty()) {
    auto item = cam.queue.pop_for(std::chrono::milliseconds(100));
    if (!item) continue;
    auto& [bgr, rec] = *item;
    bool failed;
    {
      std::lock_guard lock(cam.failure_mu);
      failed = cam.failure.has_value();
    }
    if (!failed) {
      auto index = cam.video->write(bgr, (rec.host_ns - started_host_ns_) / 1000);
      if (index) {
        rec.kept = true;
        rec.video_file_id = cam.video_file_id;
        rec.video_index = index.value();
        cam.in_video.fetch_add(1);
      } else {
        std::lock_guard lock(cam.failure_mu);
        cam.failure = index.error().message;
        spdlog::error("{}", index.error().message);
      }
    }
    if (!rec.kept) rec.reason = "video_write_failed";
    index_writer_->push(std::move(rec));
  }
}

std::optional<std::string> SessionWriter::failure() const {
  if (auto f = index_writer_->failure()) return f;
  for (const auto& cam : cameras_) {
    std::lock_guard lock(cam->failure_mu);
    if (cam->failure) return cam->failure;
  }
  return std::nullopt;
}

CameraStoreStats SessionWriter::camera_stats(std::int64_t device_id) const {
  for (const auto& cam : cameras_)
    if (cam->device_id == device_id) return {cam->in_video.load(), cam->encoder_drops.load()};
  return {};
}

Status SessionWriter::close(const std::string& end_reason) {
  if (closed_) return {};
  closed_ = true;
  Status result;
  for (auto& cam : cameras_) cam->queue.close();
  for (auto& cam : cameras_) {
    if (cam->thread.joinable()) cam->thread.join();
    if (Status s = cam->video->close(); !s.ok() && result.ok()) result = s;
  }
  index_writer_->stop();
  if (auto f = index_writer_->failure(); f && result.ok()) result = Error{*f};
  if (finalizer_ && !index_writer_->failure()) {
    try {
      sqlite::Transaction tx(index_->db());
      finalizer_(*index_);
      tx.commit();
    } catch (const std::exception& e) {
      spdlog::error("{}: re-mapping the timeline at the end failed ({}); the online values stay", dir_.string(), e.what());
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
  return result;
}

}  // namespace pvcap
