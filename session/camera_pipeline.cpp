#include "session/camera_pipeline.h"

#include <cstring>
#include <map>
#include <string_view>
#include <thread>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "capture/pixel_format.h"
#include "core/fault_injection.h"
#include "core/frame_pool.h"
#include "core/time.h"

namespace pvcap::session {

namespace {

using namespace std::chrono_literals;

// What a camera's worker holds while the timeline decides whether a frame is in a sample:
// its index row and a copy of its pixels (the camera gets its buffer back at once).
struct HeldFrame {
  FrameRecord rec;
  std::vector<std::uint8_t> pixels;
  std::uint32_t pixel_format = 0;
  int width = 0, height = 0;
};

}  // namespace

void Preview::set(cv::Mat small, cv::Mat full, std::int64_t host_ns) {
  std::lock_guard lock(mu_);
  bgr_ = std::move(small);
  full_ = std::move(full);
  host_ns_ = host_ns;
}

std::pair<cv::Mat, std::int64_t> Preview::get_full() const {
  std::lock_guard lock(mu_);
  return {full_.clone(), host_ns_};
}

std::pair<cv::Mat, std::int64_t> Preview::get() const {
  std::lock_guard lock(mu_);
  return {bgr_.clone(), host_ns_};
}

void run_camera_pipeline(const CameraPipeline& p) {
  AravisCamera& camera = p.camera;
  const int index = p.index;
  const std::int64_t device_id = p.device_id;
  SessionWriter& writer = p.writer;
  CameraTally& tally = p.tally;
  sync::SessionTimeline& timeline = p.timeline;
  TimelineEnd& end = p.end;
  const std::size_t encoder_queue = p.encoder_queue;
  const bool raw_video = writer.stores_raw(device_id);
  std::int64_t next_preview_ns = 0;
  std::uint32_t connection = UINT32_MAX;
  std::map<std::pair<std::uint32_t, std::uint64_t>, HeldFrame> held;
  // Pixel buffers are reused: a fresh 2 MB allocation per frame costs page faults by the thousand.
  std::vector<std::vector<std::uint8_t>> spare;
  auto recycle = [&](std::vector<std::uint8_t>&& pixels) {
    if (spare.size() < 32) spare.push_back(std::move(pixels));
  };
  // So are the images for the encoder (mosaics or debayered): one for each it can hold, and the one
  // being filled.
  FramePool images(encoder_queue + 2);
  // The frames the driver knows were lost, each run with its reason: a row in the store at once.
  auto record_losses = [&] {
    while (auto loss = camera.losses().pop_for(0ms)) {
      const std::string_view reason = loss->reason;
      auto& counter = reason == "queue_overflow"    ? tally.queue_overflow
                      : reason == "buffer_underrun" ? tally.buffer_underrun
                                                    : tally.not_received;
      counter.fetch_add(loss->count, std::memory_order_relaxed);
      writer.record(DropRecord{device_id, loss->connection, loss->first, loss->count, loss->reason, loss->noticed.ns});
    }
  };
  // The timeline's verdicts: the kept frame of a sample goes to the video, the others to the index.
  auto apply_decisions = [&] {
    for (const auto& d : timeline.take_decisions(index)) {
      auto it = held.find({d.connection, d.sequence});
      if (it == held.end()) continue;
      HeldFrame h = std::move(it->second);
      held.erase(it);
      if (!d.kept) {
        h.rec.reason = d.reason;
        writer.record(std::move(h.rec));
        recycle(std::move(h.pixels));
        continue;
      }
      // Raw video takes the sensor's own mosaic (no demosaicing here); colour video a BGR image.
      const bool raw = raw_video && is_bayer(h.pixel_format);
      const int raw_type = bayer_bit_depth(h.pixel_format) > 8 ? CV_16UC1 : CV_8UC1;
      cv::Mat image = images.acquire(h.height, h.width, raw ? raw_type : CV_8UC3);
      const std::size_t bytes = image.total() * image.elemSize();
      Status converted;
      if (!raw) {
        converted = to_bgr(h.pixels.data(), h.pixels.size(), h.width, h.height, h.pixel_format, image);
      } else if (h.pixels.size() < bytes) {
        converted = Error{fmt::format("frame has {} bytes, a {}x{} mosaic needs {}", h.pixels.size(), h.width,
                                      h.height, bytes)};
      } else {
        std::memcpy(image.data, h.pixels.data(), bytes);
      }
      recycle(std::move(h.pixels));
      if (!converted) {
        h.rec.reason = "unsupported_pixels: " + converted.error().message;
      } else {
        if (writer.submit_video(device_id, std::move(image), h.rec)) continue;  // the encoder records it
        tally.encoder_behind.fetch_add(1, std::memory_order_relaxed);
        h.rec.reason = "encoder_behind";
      }
      writer.record(std::move(h.rec));
    }
  };
  // A worker that falls behind, on purpose (core/fault_injection.h): tests meet buffer underruns
  // and queue overflows through the real session.
  std::optional<Stall> stall = p.stall;
  std::int64_t first_frame_ns = 0;
  auto& queue = camera.frames();
  while (!queue.closed_and_empty() || !camera.losses().closed_and_empty()) {
    auto frame = queue.pop_for(100ms);
    record_losses();
    apply_decisions();
    // The timeline decides within a quarter second; a frame held far longer means it never will:
    // record it rather than hold its pixels without bound.
    const std::int64_t give_up_before = host_now().ns - 5'000'000'000;
    for (auto it = held.begin(); it != held.end();)
      if (it->second.rec.host_ns < give_up_before) {
        it->second.rec.reason = "undecided";
        writer.record(std::move(it->second.rec));
        it = held.erase(it);
      } else {
        ++it;
      }
    // Timestamp-latch probes of this camera's clock (cameras that have the latch).
    while (auto probe = camera.clock_probes().pop_for(0ms))
      if (probe->connection == connection)
        timeline.camera_probe(index, probe->device, probe->host_lo, probe->host_hi);
    if (!frame) continue;
    if (first_frame_ns == 0) first_frame_ns = frame->host_ts.ns;
    if (stall && frame->host_ts.ns - first_frame_ns >= std::int64_t(stall->after_s * 1e9)) {
      std::this_thread::sleep_for(std::chrono::duration<double>(stall->seconds));
      stall.reset();
    }
    tally.received.fetch_add(1, std::memory_order_relaxed);
    connection = frame->connection;
    FrameRecord rec{device_id, frame->connection, frame->sequence, frame->frame_id, frame->device_ts.ns,
                    frame->host_ts.ns, frame->aravis_system_ns, to_string(frame->status), false, "", {}, {}, {}, {}};
    if (frame->identity != FrameIdentity::Own) {
      // A buffer that is not the frame it names (the frame it was is counted in a gap): recorded,
      // never used. Without a frame id it has sequence 0, unknown.
      tally.unidentified.fetch_add(1, std::memory_order_relaxed);
      rec.reason = frame->identity == FrameIdentity::NoFrameId ? "no_frame_id_" + frame->detail
                   : frame->identity == FrameIdentity::Duplicate ? std::string("duplicate_frame_id")
                                                                 : "stale_metadata_" + frame->detail;
    } else if (frame->status != FrameStatus::Good) {
      tally.incomplete.fetch_add(1, std::memory_order_relaxed);
      rec.reason = frame->detail;
    } else {
      tally.good.fetch_add(1, std::memory_order_relaxed);
      // Only complete frames with their own id and timestamp feed the clock model and the samples.
      // The arrival it fits is the leader packet's, which Aravis stamps (CLOCK_REALTIME, us): the
      // frame's first sign of life, without its payload's transfer time, which grows with load.
      const std::int64_t leader_ns = frame->aravis_system_ns + (host_now().ns - wall_now_ns());
      const bool leader_usable = frame->aravis_system_ns > 0 && leader_ns <= frame->host_ts.ns &&
                                 frame->host_ts.ns - leader_ns < 1'000'000'000;
      rec.mapped_ns = timeline
                          .camera_frame(index, frame->connection, frame->sequence, frame->device_ts,
                                        leader_usable ? HostNs{leader_ns} : frame->host_ts)
                          .ns;
      std::vector<std::uint8_t> pixels;
      if (!spare.empty()) {
        pixels = std::move(spare.back());
        spare.pop_back();
      }
      pixels.assign(frame->data, frame->data + frame->size);  // reuses the capacity
      tally.last_good_host_ns.store(frame->host_ts.ns, std::memory_order_relaxed);
      // A preview every 0.7 s: a 1080p conversion costs ~10 ms, and a period that is no round number
      // does not lock onto a rhythm of the participant (a press every second would otherwise show
      // the same phase in every preview, and the operator could never mark a fingertip mid-press).
      if (frame->host_ts.ns >= next_preview_ns) {
        next_preview_ns = frame->host_ts.ns + 700'000'000;
        cv::Mat full;
        if (to_bgr(pixels.data(), pixels.size(), frame->width, frame->height, frame->pixel_format, full).ok()) {
          cv::Mat small;
          const double scale = 320.0 / std::max(1, frame->width);
          cv::resize(full, small, {}, scale, scale, cv::INTER_AREA);
          p.preview.set(std::move(small), std::move(full), frame->host_ts.ns);
        }
      }
      HeldFrame h{std::move(rec), std::move(pixels), frame->pixel_format, frame->width, frame->height};
      frame->lease.reset();  // the camera gets its buffer back before we encode
      held.emplace(std::make_pair(h.rec.connection, h.rec.sequence), std::move(h));
      apply_decisions();
      continue;
    }
    writer.record(std::move(rec));
  }
  record_losses();
  // The last worker to finish feeding makes the timeline decide what is pending.
  if (end.feeding.fetch_sub(1) == 1) {
    timeline.flush();
    end.flushed.store(true);
  }
  while (!end.flushed.load()) std::this_thread::sleep_for(5ms);
  apply_decisions();
  for (auto& [key, h] : held) {  // nothing should be left; if it is, it is still recorded
    h.rec.reason = "undecided";
    writer.record(std::move(h.rec));
  }
}

}  // namespace pvcap::session
