#include "session/camera_pipeline.h"

#include <climits>
#include <cmath>
#include <cstring>
#include <map>
#include <string_view>
#include <thread>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "codec/pixel_format.h"
#include "core/frame_pool.h"
#include "core/thread_name.h"
#include "core/time.h"
#include "storage/video/frame_checksum.h"

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

TimelineEnd::TimelineEnd(std::size_t cameras) : caught_up_(cameras) {
  for (auto& c : caught_up_) c.store(INT64_MIN);
}

void TimelineEnd::caught_up(int camera, std::int64_t host_ns) {
  caught_up_[std::size_t(camera)].store(host_ns, std::memory_order_relaxed);
}

// Why it matters: the frames held for the last instants waited, before, until every camera had
// stopped (the timeline's flush); under load that took 1-2 s, and those frames were what a power
// cut in the stop took (docs/store.md).
std::int64_t TimelineEnd::settled_before() const {
  std::int64_t mark = INT64_MAX;
  for (const auto& c : caught_up_) mark = std::min(mark, c.load(std::memory_order_relaxed));
  if (mark == INT64_MIN) return INT64_MIN;  // a worker has taken nothing yet
  return mark == INT64_MAX ? INT64_MAX : mark - kArrivalNs;
}

void Preview::set(cv::Mat small, cv::Mat full, std::int64_t host_ns) {
  std::lock_guard lock(mu_);
  bgr_ = std::move(small);
  full_ = std::move(full);
  host_ns_ = host_ns;
}

std::pair<cv::Mat, std::int64_t> Preview::get_full(std::int64_t newer_than_ns) const {
  std::lock_guard lock(mu_);
  if (host_ns_ <= newer_than_ns) return {cv::Mat(), host_ns_};
  return {full_.clone(), host_ns_};
}

std::pair<cv::Mat, std::int64_t> Preview::get() const {
  std::lock_guard lock(mu_);
  return {bgr_.clone(), host_ns_};
}

namespace {

// One camera's worker: its frames from the driver to the timeline and the store. Holds each good
// frame's pixels until the timeline says whether it is in a sample.
class CameraWorker {
 public:
  explicit CameraWorker(const CameraPipeline& p)
      : p_(p),
        raw_video_(p.writer.stores_raw(p.device_id)),
        plane_order_(p.writer.raw_plane_order(p.device_id)),
        images_(p.encoder_queue + 2),
        stall_(p.stall) {}

  void run() {
    warm_up();
    if (p_.warmed) p_.warmed->count_down();
    while (!p_.camera.frames_done() || !p_.camera.losses().closed_and_empty()) {
      auto frame = p_.camera.next_frame(100ms);
      p_.end.caught_up(p_.index, frame ? frame->host_ts.ns : host_now().ns);
      record_losses();
      apply_decisions();
      if (!p_.end.stopping.load())
        give_up_undecided(host_now().ns - 5'000'000'000);
      else  // instants no frame can still join are decided now, not once the slowest camera has stopped
        p_.timeline.settle(HostNs{p_.end.settled_before()});
      take_clock_probes();
      if (frame) take(*frame);
    }
    record_losses();
    p_.end.caught_up(p_.index, INT64_MAX);
    // The last worker to finish feeding makes the timeline decide what is pending.
    if (p_.end.feeding.fetch_sub(1) == 1) {
      p_.timeline.flush();
      p_.end.flushed.store(true);
    }
    // Meanwhile its held frames go on as the others' settling decides them (a camera slow to stop
    // would otherwise keep this one's last frames from the disk until it has).
    while (!p_.end.flushed.load()) {
      p_.timeline.settle(HostNs{p_.end.settled_before()});
      apply_decisions();
      std::this_thread::sleep_for(5ms);
    }
    apply_decisions();
    give_up_undecided(INT64_MAX);  // nothing should be left; if it is, it is still recorded
  }

 private:
  // The buffers the first second needs, written once before the camera starts: the first touch of a
  // fresh 2 MB buffer page-faults it in (2-7 ms on the project's VMs), and taken as frames came, that
  // fell on the first second, beside every camera's stream starting (on one VM 1-5 frames per camera
  // were lost at the start; docs/performance-log.md, "The first second"). Enough copies for the frames
  // held while the timeline decides (about a quarter second) with room, and a few encoder images.
  void warm_up() {
    const CameraSettings s = p_.camera.settings();
    const std::uint32_t format = pixel_format_code(s.pixel_format);
    if (s.payload == 0 || s.width <= 0 || s.height <= 0) return;
    const std::size_t held = std::min<std::size_t>(kMaxSpare, std::size_t(std::ceil(s.frame_rate * 0.5)) + 4);
    while (spare_.size() < held) spare_.emplace_back(s.payload);  // value-initialised: every page written
    const bool raw = raw_video_ && is_bayer(format);
    const int type = !raw ? CV_8UC3 : bayer_bit_depth(format) > 8 ? CV_16UC1 : CV_8UC1;
    std::vector<cv::Mat> images;
    for (std::size_t i = 0; i < std::min<std::size_t>(4, p_.encoder_queue + 2); ++i) {
      images.push_back(images_.acquire(s.height, s.width, type));
      images.back().setTo(0);
    }
  }

  // The frames the driver knows were lost, each run with its reason: a row in the store at once.
  void record_losses() {
    while (auto loss = p_.camera.losses().pop_for(0ms)) {
      const std::string_view reason = loss->reason;
      auto& counter = reason == "buffer_underrun" ? p_.tally.buffer_underrun : p_.tally.not_received;
      counter.fetch_add(loss->count, std::memory_order_relaxed);
      p_.writer.record(
          DropRecord{p_.device_id, loss->connection, loss->first, loss->count, loss->reason, loss->noticed.ns});
    }
  }

  // The timeline's verdicts: the kept frame of a sample goes to the video, the others to the index.
  void apply_decisions() {
    for (const auto& d : p_.timeline.take_decisions(p_.index)) {
      auto it = held_.find({d.connection, d.sequence});
      if (it == held_.end()) continue;
      HeldFrame h = std::move(it->second);
      held_.erase(it);
      if (!d.kept) {
        h.rec.reason = d.reason;
        p_.writer.record(std::move(h.rec));
        recycle(std::move(h.pixels));
        continue;
      }
      encode(std::move(h));
    }
  }

  // A kept frame to its encoder: raw video takes the sensor's own mosaic (no demosaicing here),
  // colour video a BGR image.
  void encode(HeldFrame h) {
    const bool raw = raw_video_ && is_bayer(h.pixel_format);
    const int raw_type = bayer_bit_depth(h.pixel_format) > 8 ? CV_16UC1 : CV_8UC1;
    cv::Mat image = images_.acquire(h.height, h.width, raw ? raw_type : CV_8UC3);
    const std::size_t bytes = image.total() * image.elemSize();
    Status converted;
    if (!raw) {
      converted = to_bgr(h.pixels.data(), h.pixels.size(), h.width, h.height, h.pixel_format, image);
    } else if (h.pixels.size() < bytes) {
      converted =
          Error{fmt::format("frame has {} bytes, a {}x{} mosaic needs {}", h.pixels.size(), h.width, h.height, bytes)};
    } else {
      std::memcpy(image.data, h.pixels.data(), bytes);
      // The frame's checksum, taken from the camera's bytes before anything encodes them: verify and
      // the reader compare every decoded frame with it (storage/video/frame_checksum.h).
      h.rec.checksum = stored_mosaic_crc(image, plane_order_);
    }
    recycle(std::move(h.pixels));
    if (!converted) {
      h.rec.reason = "unsupported_pixels: " + converted.error().message;
    } else {
      if (p_.writer.submit_video(p_.device_id, std::move(image), h.rec)) return;  // the encoder records it
      if (p_.writer.writes_failed()) {
        h.rec.reason = "storage_failed";  // the disk refused a write: nothing more is written
      } else {
        p_.tally.encoder_behind.fetch_add(1, std::memory_order_relaxed);
        h.rec.reason = "encoder_behind";
      }
    }
    p_.writer.record(std::move(h.rec));
  }

  // The timeline decides within a quarter second; a frame held far longer means it never will:
  // recorded rather than its pixels held without bound.
  void give_up_undecided(std::int64_t arrived_before_ns) {
    for (auto it = held_.begin(); it != held_.end();)
      if (it->second.rec.host_ns < arrived_before_ns) {
        it->second.rec.reason = "undecided";
        p_.writer.record(std::move(it->second.rec));
        it = held_.erase(it);
      } else {
        ++it;
      }
  }

  // Timestamp-latch probes of this camera's clock (cameras that have the latch). A connection's
  // first probe is taken as acquisition starts, before its first frame: the clock model keeps the
  // session's first for the segment its first frame begins; a reconnection's joins the current
  // segment, where a probe of a clock reset meanwhile lies far back and is dropped. Probes of a
  // connection already left behind are not taken.
  void take_clock_probes() {
    while (auto probe = p_.camera.clock_probes().pop_for(0ms))
      if (connection_ == UINT32_MAX || probe->connection >= connection_)
        p_.timeline.camera_probe(p_.index, probe->device, probe->host_lo, probe->host_hi);
  }

  void take(CameraFrame& frame) {
    if (first_frame_ns_ == 0) first_frame_ns_ = frame.host_ts.ns;
    // A worker that falls behind, on purpose (core/fault_injection.h): tests meet buffer underruns
    // and queue overflows through the real session.
    if (stall_ && frame.host_ts.ns - first_frame_ns_ >= std::int64_t(stall_->after_s * 1e9)) {
      std::this_thread::sleep_for(std::chrono::duration<double>(stall_->seconds));
      stall_.reset();
    }
    p_.tally.received.fetch_add(1, std::memory_order_relaxed);
    if (frame.arrival_late) p_.tally.arrivals_late.fetch_add(1, std::memory_order_relaxed);
    connection_ = frame.connection;
    FrameRecord rec{p_.device_id,
                    frame.connection,
                    frame.sequence,
                    frame.frame_id,
                    frame.device_ts.ns,
                    frame.host_ts.ns,
                    frame.aravis_system_ns,
                    to_string(frame.status),
                    false,
                    "",
                    {},
                    {},
                    {},
                    {}};
    if (frame.chunks.frame_counter) rec.chunk_frame_counter = std::int64_t(*frame.chunks.frame_counter);
    rec.chunk_timestamp = frame.chunks.timestamp;
    rec.chunk_exposure_us = frame.chunks.exposure_us;
    rec.chunk_gain = frame.chunks.gain;
    rec.chunk_line_status = frame.chunks.line_status;
    if (frame.identity != FrameIdentity::Own) {
      // A buffer that is not the frame it names (the frame it was is counted in a gap): recorded,
      // never used, with sequence 0 (unknown). The id it carries (kept in frame_id) is another
      // frame's, and a second row under that frame's key would stand beside it in every join.
      p_.tally.unidentified.fetch_add(1, std::memory_order_relaxed);
      if (frame.identity == FrameIdentity::Foreign) p_.tally.foreign.fetch_add(1, std::memory_order_relaxed);
      rec.sequence = 0;
      rec.reason = frame.identity == FrameIdentity::NoFrameId   ? "no_frame_id_" + frame.detail
                   : frame.identity == FrameIdentity::Duplicate ? std::string("duplicate_frame_id")
                   : frame.identity == FrameIdentity::Foreign   ? "foreign_frame_" + frame.detail
                                                                : "stale_metadata_" + frame.detail;
    } else if (frame.status != FrameStatus::Good) {
      p_.tally.incomplete.fetch_add(1, std::memory_order_relaxed);
      rec.reason = frame.detail;
    } else {
      take_good(frame, std::move(rec));
      return;
    }
    p_.writer.record(std::move(rec));
  }

  // Only complete frames with their own id and timestamp feed the clock model and the samples.
  void take_good(CameraFrame& frame, FrameRecord rec) {
    p_.tally.good.fetch_add(1, std::memory_order_relaxed);
    // The arrival it fits is the leader packet's, which Aravis stamps (CLOCK_REALTIME, us): the
    // frame's first sign of life, without its payload's transfer time, which grows with load.
    const std::int64_t leader_ns = frame.aravis_system_ns + (host_now().ns - wall_now_ns());
    const bool leader_usable =
        frame.aravis_system_ns > 0 && leader_ns <= frame.host_ts.ns && frame.host_ts.ns - leader_ns < 1'000'000'000;
    // The image's instant: the camera's constant offset (the timeline's) and, where the frame's chunks
    // give its own exposure, the difference that makes (capture/aravis_chunks.h).
    rec.mapped_ns = p_.timeline
                        .camera_frame(p_.index, frame.connection, frame.sequence,
                                      DeviceNs{frame.device_ts.ns + frame.instant_correction_ns},
                                      leader_usable ? HostNs{leader_ns} : frame.host_ts)
                        .ns;
    std::vector<std::uint8_t> pixels;
    if (!spare_.empty()) {
      pixels = std::move(spare_.back());
      spare_.pop_back();
    }
    pixels.assign(frame.data, frame.data + frame.size);  // reuses the capacity
    p_.tally.last_good_host_ns.store(frame.host_ts.ns, std::memory_order_relaxed);
    if (p_.light_monitor && rec.mapped_ns) meter(frame, *rec.mapped_ns);
    update_preview(frame, pixels);
    HeldFrame h{std::move(rec), std::move(pixels), frame.pixel_format, frame.width, frame.height};
    frame.lease.reset();  // the camera gets its buffer back before we encode
    held_.emplace(std::make_pair(h.rec.connection, h.rec.sequence), std::move(h));
    apply_decisions();
  }

  // A preview every 0.7 s: a 1080p conversion costs ~10 ms, and a period that is no round number does
  // not lock onto a rhythm of the participant (a press every second would otherwise show the same
  // phase in every preview, and the operator could never mark a fingertip mid-press).
  void update_preview(const CameraFrame& frame, const std::vector<std::uint8_t>& pixels) {
    if (frame.host_ts.ns < next_preview_ns_) return;
    next_preview_ns_ = frame.host_ts.ns + 700'000'000;
    cv::Mat full;
    if (!to_bgr(pixels.data(), pixels.size(), frame.width, frame.height, frame.pixel_format, full).ok()) return;
    cv::Mat small;
    const double scale = 320.0 / std::max(1, frame.width);
    cv::resize(full, small, {}, scale, scale, cv::INTER_AREA);
    p_.preview.set(std::move(small), std::move(full), frame.host_ts.ns);
  }

  // The frame's light level, as it would read at the connection's first exposure and gain (its chunks'),
  // for the lights' confirmation (session/recording_lights.cpp).
  void meter(const CameraFrame& frame, std::int64_t t_ns) {
    if (frame.width != meter_width_ || frame.height != meter_height_) {
      meter_width_ = frame.width, meter_height_ = frame.height;
      const std::size_t pixels = std::size_t(std::max(1, frame.width)) * std::size_t(std::max(1, frame.height));
      const int bytes = int(std::max<std::size_t>(1, image_bytes(frame.width, frame.height, frame.pixel_format) / pixels));
      meter_grid_ = lighting::meter_grid(frame.width, frame.height, bytes, p_.pad_corners_px);
    }
    const auto levels = lighting::meter_levels(frame.data, frame.size, meter_grid_);
    const double exposure = frame.chunks.exposure_us.value_or(0), gain = frame.chunks.gain.value_or(0);
    if (reference_exposure_us_ <= 0 && exposure > 0) reference_exposure_us_ = exposure, reference_gain_ = gain;
    for (std::size_t r = 0; r < levels.size(); ++r) {
      if (std::isnan(levels[r])) continue;
      const double level = exposure > 0 ? lighting::normalised_level(levels[r], exposure, gain,
                                                                     reference_exposure_us_, reference_gain_)
                                        : levels[r];
      // One channel per region of each camera (lighting/light_monitor.h).
      p_.light_monitor->add(std::size_t(p_.index) * lighting::kMeterRegions + r, t_ns, level);
    }
  }

  // Pixel buffers are reused: a fresh 2 MB allocation per frame costs page faults by the thousand.
  void recycle(std::vector<std::uint8_t>&& pixels) {
    if (spare_.size() < kMaxSpare) spare_.push_back(std::move(pixels));
  }

  const CameraPipeline& p_;
  const bool raw_video_;
  const PlaneOrder plane_order_;  // how the raw video stacks the planes the checksum runs over
  // So are the images for the encoder (mosaics or debayered): one for each it can hold, and the one
  // being filled.
  FramePool images_;
  static constexpr std::size_t kMaxSpare = 32;
  std::optional<Stall> stall_;
  std::map<std::pair<std::uint32_t, std::uint64_t>, HeldFrame> held_;
  std::vector<std::vector<std::uint8_t>> spare_;
  std::int64_t next_preview_ns_ = 0, first_frame_ns_ = 0;
  lighting::MeterGrid meter_grid_;
  int meter_width_ = 0, meter_height_ = 0;
  double reference_exposure_us_ = 0, reference_gain_ = 0;
  std::uint32_t connection_ = UINT32_MAX;
};

}  // namespace

void run_camera_pipeline(const CameraPipeline& p) {
  name_this_thread("work-" + p.camera.config().name);
  CameraWorker(p).run();
}

}  // namespace pvcap::session
