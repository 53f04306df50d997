// Each camera's encoder thread of SessionWriter: kept frames from its queue (memory, then the spill)
// to its video segments and view videos, then their index rows.
#include "storage/writer/session_writer.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "core/time.h"
#include "storage/video/view_video.h"
#include "storage/writer/session_writer_internal.h"

namespace pvcap {

namespace {
// How much nicer than the recorder's other threads an encoder runs (encode_loop).
constexpr int kEncoderNiceStep = 5;
}  // namespace

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

namespace {
// What the next raw HuffYUV segment's Huffman tables are fitted to: the residuals of the last frame
// written (8 % fewer bytes on a noisy sensor than HuffYUV's generic tables, decoded as fast;
// bench/lossless_bench "stored layouts"). Empty for other videos; a camera's first segment, opened
// before any frame, has the generic tables.
std::vector<std::uint64_t> fitted_table_counts(const VideoSettings& settings, const VideoWriter& video) {
  std::vector<std::uint64_t> counts;
  const cv::Mat last = video.stored_planes();
  if (settings.raw() && settings.raw_codec == "ffvhuff" && last.type() == CV_8UC1 && !last.empty())
    add_left_residual_counts(last, counts);
  return counts;
}
}  // namespace

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
    if (writes_failed()) {
      abandon_backlog(cam);
      break;
    }
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
      std::vector<std::uint64_t> residual_counts = fitted_table_counts(cam.settings, *cam.video);
      const std::int64_t id = cam.video_file_id, frames = cam.video->frames_written();
      close_view(cam);
      if (Status s = cam.video->close(); !s.ok()) {
        cam.failed_files.push_back(id);
        cam.failed.store(true);
        set_failure(s.error().message);
      } else {
        index_writer_->push(VideoFileClosed{id, frames});
        queue.release_finished();  // spilled frames in the finished segment are safe on disk now
        if (Status o = open_segment(cam, pts_us, false, std::move(residual_counts)); !o.ok()) {
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

// After the disk refused a write, every frame more written would take space the index needs to
// finish (on a full disk, the reserve): the frames waiting in memory are recorded as lost, with why;
// those in the spill stay there for `pvcap recover` to encode once there is room.
void SessionWriter::abandon_backlog(Camera& cam) {
  auto lost = cam.queue->abandon();
  const std::size_t spilled = cam.queue->on_disk();
  if (!lost.empty() || spilled > 0)
    spdlog::warn("{}: the disk failed a write: {} frames waiting in memory are lost{}", cam.name, lost.size(),
                 spilled > 0 ? fmt::format(", {} in the spill stay there for 'pvcap recover'", spilled) : "");
  for (auto& item : lost) {
    cam.encoder_drops.fetch_add(1);
    item.rec.reason = item.lost_reason;
    index_writer_->push(std::move(item.rec));
  }
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

}  // namespace pvcap
