#include "app/recorder.h"

#include "app/realign.h"

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <map>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "capture/aravis_camera.h"
#include "capture/pixel_format.h"
#include "capture/sensel_device.h"
#include "core/frame_pool.h"
#include "core/gap_tracker.h"
#include "core/log.h"
#include "core/sequence_unwrap.h"
#include "core/time.h"
#include "storage/session_writer.h"
#include "sync/session_timeline.h"

extern char** environ;

namespace pvcap {

namespace {

using namespace std::chrono_literals;

// Per-camera counts the operator sees, filled by that camera's worker thread.
struct CameraTally {
  std::atomic<std::uint64_t> received{0}, good{0}, incomplete{0}, not_received{0}, encoder_behind{0}, lost_events{0};
  std::atomic<std::uint64_t> unidentified{0};  // buffers without their own id/timestamp, or duplicate ids
};

// The simulator runs as a child process in our network namespace, like a separate box on the wire.
class SimProcess {
 public:
  SimProcess(const std::filesystem::path& exe, const std::filesystem::path& rig, const std::filesystem::path& truth) {
    std::vector<std::string> args = {exe.string(), "--log-level", "warn", "sim", "--rig", rig.string(),
                                     "--truth", truth.string()};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    if (posix_spawn(&pid_, exe.c_str(), nullptr, nullptr, argv.data(), environ) != 0) pid_ = -1;
  }
  ~SimProcess() {
    if (pid_ <= 0) return;
    kill(pid_, SIGTERM);
    int status = 0;
    for (int i = 0; i < 50 && waitpid(pid_, &status, WNOHANG) == 0; ++i) std::this_thread::sleep_for(100ms);
    if (waitpid(pid_, &status, WNOHANG) == 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, &status, 0);
    }
  }
  bool started() const { return pid_ > 0; }

 private:
  pid_t pid_ = -1;
};

std::string settings_json(const CameraSettings& s, const CameraConfig& c) {
  nlohmann::json j = {{"pixel_format", s.pixel_format}, {"x", s.x}, {"y", s.y}, {"width", s.width},
                      {"height", s.height}, {"frame_rate", s.frame_rate}, {"exposure_us", s.exposure_us},
                      {"gain", s.gain}, {"trigger", s.trigger}, {"packet_size", s.packet_size},
                      {"payload", s.payload}, {"buffer_count", s.buffer_count},
                      {"timestamp_tick_hz", s.timestamp_tick_hz}, {"device_id", s.device_id},
                      {"packet_resend", c.packet_resend}, {"socket_buffer_bytes", c.socket_buffer_bytes},
                      {"latency_ns", c.latency_ns}};
  return j.dump();
}

// What a camera's worker holds while the timeline decides whether a frame is in a sample:
// its index row and a copy of its pixels (the camera gets its buffer back at once).
struct HeldFrame {
  FrameRecord rec;
  std::vector<std::uint8_t> pixels;
  std::uint32_t pixel_format = 0;
  int width = 0, height = 0;
};

// Tells the camera workers when the timeline has decided everything (after the last frame).
struct TimelineEnd {
  std::atomic<int> feeding{0};
  std::atomic<bool> flushed{false};
};

void camera_worker(AravisCamera& camera, int index, std::int64_t device_id, SessionWriter& writer, CameraTally& tally,
                   sync::SessionTimeline& timeline, TimelineEnd& end, std::size_t encoder_queue) {
  SequenceUnwrapper unwrap(16, /*zero_is_skipped=*/true);
  std::uint32_t connection = UINT32_MAX;
  std::map<std::pair<std::uint32_t, std::uint64_t>, HeldFrame> held;
  // Pixel buffers are reused: a fresh 2 MB allocation per frame costs page faults by the thousand.
  std::vector<std::vector<std::uint8_t>> spare;
  auto recycle = [&](std::vector<std::uint8_t>&& pixels) {
    if (spare.size() < 32) spare.push_back(std::move(pixels));
  };
  // So are the debayered images: one for each the encoder can hold, and the one being filled.
  FramePool images(encoder_queue + 2);
  // A frame that times out incomplete is delivered after its successor: hold gaps open for a
  // second so such a frame is counted once, as what it is.
  auto report_gap = [&](const GapTracker::Gap& g) {
    tally.not_received.fetch_add(g.count, std::memory_order_relaxed);
    writer.record(DropRecord{device_id, connection, g.first, g.count, "not_received", g.noticed_ns});
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
      cv::Mat bgr = images.acquire(h.height, h.width, CV_8UC3);
      const Status converted = to_bgr(h.pixels.data(), h.pixels.size(), h.width, h.height, h.pixel_format, bgr);
      recycle(std::move(h.pixels));
      if (!converted) {
        h.rec.reason = "unsupported_pixels: " + converted.error().message;
      } else {
        if (writer.submit_video(device_id, std::move(bgr), h.rec)) continue;  // the encoder records it
        tally.encoder_behind.fetch_add(1, std::memory_order_relaxed);
        h.rec.reason = "encoder_behind";
      }
      writer.record(std::move(h.rec));
    }
  };
  GapTracker gaps(1'000'000'000, report_gap);
  auto& queue = camera.frames();
  while (!queue.closed_and_empty()) {
    auto frame = queue.pop_for(100ms);
    gaps.settle(host_now().ns);
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
        timeline.camera_probe(index, probe->device.ns, probe->host_lo.ns, probe->host_hi.ns);
    if (!frame) continue;
    tally.received.fetch_add(1, std::memory_order_relaxed);
    if (frame->connection != connection) {  // frame ids restart with each connection
      gaps.settle(0, /*flush_all=*/true);
      unwrap = SequenceUnwrapper(16, true);
      connection = frame->connection;
    }
    if (frame->frame_id == 0) {
      // GigE Vision never sends id 0: this buffer got no leader packet, so it has no identity.
      // The frame it was is counted in a gap; record the buffer, sequence 0 = unknown.
      tally.unidentified.fetch_add(1, std::memory_order_relaxed);
      writer.record(FrameRecord{device_id, frame->connection, 0, 0, frame->device_ts.ns, frame->host_ts.ns,
                                frame->aravis_system_ns, to_string(frame->status), false,
                                "no_frame_id_" + frame->detail, {}, {}, {}});
      continue;
    }
    const auto step = unwrap.next(frame->frame_id);
    FrameRecord rec{device_id, frame->connection, step.sequence, frame->frame_id, frame->device_ts.ns,
                    frame->host_ts.ns, frame->aravis_system_ns, to_string(frame->status), false, "", {}, {}, {}};
    gaps.missing(step.sequence - step.missing, step.missing, frame->host_ts.ns);
    if (step.out_of_order && !gaps.arrived_late(step.sequence)) {
      // Not a frame we were missing. An incomplete buffer whose leader packet was lost still
      // carries the id and timestamp of the buffer's previous frame (seen with Aravis 0.8):
      // the frame it really was is already counted in a gap, so it is recorded, not counted.
      tally.unidentified.fetch_add(1, std::memory_order_relaxed);
      rec.reason = frame->status == FrameStatus::Good ? "duplicate_frame_id" : "stale_metadata_" + frame->detail;
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
      rec.mapped_ns = timeline.camera_frame(index, frame->connection, step.sequence, frame->device_ts.ns,
                                            leader_usable ? leader_ns : frame->host_ts.ns);
      std::vector<std::uint8_t> pixels;
      if (!spare.empty()) {
        pixels = std::move(spare.back());
        spare.pop_back();
      }
      pixels.assign(frame->data, frame->data + frame->size);  // reuses the capacity
      HeldFrame h{std::move(rec), std::move(pixels), frame->pixel_format, frame->width, frame->height};
      frame->lease.reset();  // the camera gets its buffer back before we encode
      held.emplace(std::make_pair(h.rec.connection, h.rec.sequence), std::move(h));
      apply_decisions();
      continue;
    }
    writer.record(std::move(rec));
  }
  gaps.settle(0, /*flush_all=*/true);
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

// The Sensel's part of a session: open before anything is on disk, then a worker that
// moves its samples into the store, one row per frame, at full rate.
class SenselRecording {
 public:
  // Over USB by serial, or over a tty: a device path, or "sim" with `sim_dir` holding the
  // simulator's sensel.tty link.
  static Result<std::unique_ptr<SenselRecording>> open(const SenselRigConfig& cfg, const std::filesystem::path& sim_dir,
                                                        double wait_s, const std::atomic<bool>& stop_requested) {
    std::unique_ptr<SenselRecording> r(new SenselRecording());
    r->config_ = cfg;
    const std::string path = cfg.tty == "sim" ? (sim_dir / "sensel.tty").string() : cfg.tty;
    sensel::SenselDevice::TransportFactory factory;
    if (cfg.usb_serial) factory = [serial = *cfg.usb_serial] { return sensel::open_usb(serial); };
    else factory = [path] { return sensel::open_tty(path); };
    const char* key = cfg.usb_serial ? "sensel.usb" : "sensel.tty";
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(wait_s);
    for (;;) {
      auto d = sensel::SenselDevice::open(factory,
                                          [raw = r.get()](const sensel::SenselEvent& e) { raw->on_event(e); });
      if (d) {
        r->device_ = std::move(d.value());
        break;
      }
      if (stop_requested.load() || std::chrono::steady_clock::now() >= deadline)
        return Error{fmt::format("Sensel ({} in the rig file, line {}): {}", key, cfg.line, d.error().message)};
      std::this_thread::sleep_for(200ms);
    }
    if (Status s = r->device_->configure({.scan_detail = cfg.scan_detail,
                                          .dynamic_baseline = cfg.dynamic_baseline,
                                          .frame_rate_cap = cfg.frame_rate_cap});
        !s.ok())
      return Error{"Sensel: " + s.error().message};
    const auto& info = r->device_->info();
    spdlog::info("sensel: Sensel Morph serial {} firmware {} on {}, grid {}x{} (scan detail {}), dynamic baselining {}",
                 info.serial, info.firmware, r->connection(), info.grid.cols, info.grid.rows,
                 cfg.scan_detail == 0 ? "high" : "medium", cfg.dynamic_baseline ? "on" : "off");
    return r;
  }

  DeviceRecord device_record() const {
    const auto& info = device_->info();
    nlohmann::json j = {{"scan_detail", config_.scan_detail == 0 ? "high" : "medium"},
                        {"grid", {info.grid.cols, info.grid.rows, info.grid.xscale, info.grid.yscale}},
                        {"dynamic_baseline", config_.dynamic_baseline}, {"frame_rate_cap", config_.frame_rate_cap},
                        {"latency_ns", config_.latency_ns}};
    if (config_.usb_serial) j["usb"] = *config_.usb_serial;
    else j["tty"] = config_.tty;
    return DeviceRecord{"sensel", "sensel", "Sensel", "Morph", info.serial, connection(), info.firmware, j.dump()};
  }

  // How the Morph is reached, for the operator and the devices table.
  std::string connection() const {
    if (!config_.usb_serial) return config_.tty;
    return config_.usb_serial->empty() ? "usb" : "usb:" + *config_.usb_serial;
  }

  Status start(SessionWriter& writer, std::int64_t device_id, sync::SessionTimeline& timeline) {
    writer_ = &writer;
    device_id_ = device_id;
    timeline_ = &timeline;
    if (Status s = device_->start(); !s.ok()) return s;
    worker_ = std::thread([this] { run(); });
    return {};
  }

  void stop() {
    device_->stop();
    if (worker_.joinable()) worker_.join();
    writer_ = nullptr;
  }

  std::uint64_t stored() const { return stored_.load(); }
  std::string summary() const {
    std::uint64_t rejected = 0;
    for (const auto& [why, n] : device_->rejected()) rejected += n;
    return fmt::format("{:<8} {:>9} frames stored, {} missing by its counter, {} rejected (stall/garbage), {} "
                       "queue overflows",
                       "sensel", stored_.load(), device_->lost_frames(), rejected, device_->queue_overflows());
  }
  bool lossy() const { return device_->lost_frames() + device_->queue_overflows() > 0 || !device_->rejected().empty(); }

 private:
  SenselRecording() = default;

  void on_event(const sensel::SenselEvent& e) {
    using K = sensel::SenselEvent::Kind;
    if (e.kind == K::Reconnected) spdlog::warn("{}", e.message);
    else spdlog::error("{}", e.message);
    static const char* kinds[] = {"sensel_stall", "sensel_garbage", "sensel_unplugged", "sensel_reconnected"};
    if (SessionWriter* w = writer_) w->record(EventRecord{e.at.ns, kinds[int(e.kind)], device_id_, e.message});
  }

  void run() {
    auto& q = device_->samples();
    SessionWriter& writer = *writer_.load();
    while (!q.closed_and_empty()) {
      auto s = q.pop_for(100ms);
      if (!s) continue;
      if (s->lost_before)
        writer.record(DropRecord{device_id_, 0, s->sequence - s->lost_before, s->lost_before, "not_received",
                                   s->host_ts.ns});
      // The clock model fits when the answer began to arrive (the midpoint is the stamp's best
      // single guess, but an arrival is what a latency floor bounds; its first bytes come before
      // the rest of a frame's 64-byte packets).
      const std::int64_t arrival = s->first_byte_ts.ns;
      const std::int64_t mapped = timeline_->pressure_frame(0, s->sequence, s->device_ts.ns, arrival);
      PressureRecord rec{device_id_, 0, s->sequence, s->lost_before, s->device_ts.ns, s->host_ts.ns, s->host_wait_ns,
                         s->grid.cols, s->grid.rows, s->grid.xscale, s->grid.yscale, {}, mapped};
      // The counts again in the store's portable form (zlib on the index's thread), for readers
      // without the Sensel codec; the device's payload is kept as it came.
      if (s->frame.pressure) {
        rec.base = s->frame.pressure->base;
        rec.counts = std::move(s->frame.pressure->counts);
      }
      rec.payload = std::move(s->payload);
      writer.record(std::move(rec));
      stored_.fetch_add(1, std::memory_order_relaxed);
    }
  }

  SenselRigConfig config_;
  std::unique_ptr<sensel::SenselDevice> device_;
  std::atomic<SessionWriter*> writer_{nullptr};
  std::int64_t device_id_ = 0;
  sync::SessionTimeline* timeline_ = nullptr;
  std::thread worker_;
  std::atomic<std::uint64_t> stored_{0};
};

Status open_with_wait(AravisCamera& camera, double wait_s, const std::atomic<bool>& stop_requested) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(wait_s);
  for (;;) {
    Status s = camera.open();
    if (s.ok() || stop_requested.load() || std::chrono::steady_clock::now() >= deadline) return s;
    std::this_thread::sleep_for(200ms);
  }
}

}  // namespace

int record_session(const RigConfig& rig, const RecordOptions& options, const std::atomic<bool>& stop_requested) {
  const std::int64_t wall0 = wall_now_ns();
  const std::int64_t host0 = host_now().ns;

  // The simulator writes its ground truth beside the sessions while it runs; once it has stopped,
  // the truth is moved into the session folder.
  std::unique_ptr<SimProcess> sim;
  std::filesystem::path truth_tmp;
  if (rig.sim) {
    truth_tmp = options.root / fmt::format(".sim-truth-{}", getpid());
    std::filesystem::create_directories(truth_tmp);
    sim = std::make_unique<SimProcess>(options.self_exe, rig.source, truth_tmp);
    if (!sim->started()) {
      spdlog::error("cannot start the camera simulator ({})", options.self_exe.string());
      return 1;
    }
  }

  // Open every camera before creating anything on disk: a rig that is not ready leaves no empty session.
  std::vector<std::unique_ptr<AravisCamera>> cameras;
  std::vector<std::unique_ptr<CameraTally>> tallies;
  SessionWriter* writer_for_events = nullptr;
  std::vector<std::int64_t> device_ids(rig.cameras.size(), 0);
  std::mutex events_mu;
  for (std::size_t i = 0; i < rig.cameras.size(); ++i) {
    tallies.push_back(std::make_unique<CameraTally>());
    cameras.push_back(std::make_unique<AravisCamera>(int(i), rig.cameras[i], [&, i](const CameraEvent& e) {
      if (e.kind == CameraEvent::Kind::Lost) {
        spdlog::error("{}", e.message);
        tallies[i]->lost_events.fetch_add(1);
      } else {
        spdlog::warn("{}", e.message);
      }
      std::lock_guard lock(events_mu);
      if (writer_for_events)
        writer_for_events->record(EventRecord{
            e.at.ns, e.kind == CameraEvent::Kind::Lost ? "camera_lost" : "camera_reconnected", device_ids[i],
            e.message});
    }));
  }
  for (auto& cam : cameras) {
    if (Status s = open_with_wait(*cam, options.device_wait_s, stop_requested); !s.ok()) {
      spdlog::error("{}", s.error().message);
      spdlog::error("no session was recorded: every camera of {} must be ready", rig.source.string());
      if (!truth_tmp.empty()) std::filesystem::remove_all(truth_tmp);
      return 1;
    }
  }

  std::unique_ptr<SenselRecording> sensel;
  if (rig.sensel) {
    auto opened = SenselRecording::open(*rig.sensel, truth_tmp, rig.sim ? 10.0 : 2.0, stop_requested);
    if (!opened) {
      spdlog::error("{}", opened.error().message);
      spdlog::error("no session was recorded: the Sensel of {} must be ready", rig.source.string());
      if (!truth_tmp.empty()) std::filesystem::remove_all(truth_tmp);
      return 1;
    }
    sensel = std::move(opened.value());
  }

  auto created = SessionWriter::create(options.root, rig, wall0, host0);
  if (!created) {
    spdlog::error("{}", created.error().message);
    if (!truth_tmp.empty()) std::filesystem::remove_all(truth_tmp);
    return 1;
  }
  SessionWriter& writer = *created.value();
  log::add_session_file(writer.dir());
  struct SessionLogGuard {
    ~SessionLogGuard() { log::remove_session_file(); }
  } session_log_guard;
  spdlog::info("recording session {}", writer.dir().string());

  for (std::size_t i = 0; i < cameras.size(); ++i) {
    const CameraSettings s = cameras[i]->settings();
    DeviceRecord d{"camera", rig.cameras[i].name, s.vendor, s.model, s.serial, s.address, s.firmware,
                   settings_json(s, rig.cameras[i])};
    auto id = writer.add_camera(d, s.width, s.height);
    if (!id) {
      spdlog::error("{}", id.error().message);
      (void)writer.close("failed to start");
      return 1;
    }
    device_ids[i] = id.value();
  }
  for (Status s : {options.participant ? writer.set_participant(*options.participant) : Status{},
                   options.conditions ? writer.set_conditions(*options.conditions) : Status{}})
    if (!s.ok()) {
      spdlog::error("{}", s.error().message);
      (void)writer.close("failed to start");
      return 1;
    }
  std::int64_t sensel_id = 0;
  if (sensel) {
    auto id = writer.add_device(sensel->device_record());
    if (!id) {
      spdlog::error("{}", id.error().message);
      (void)writer.close("failed to start");
      return 1;
    }
    sensel_id = id.value();
  }
  {
    std::lock_guard lock(events_mu);
    writer_for_events = &writer;
  }
  writer.start();

  // The timeline: every stream on this host's clock, camera frames grouped by instant, one group per
  // tick of the sample grid, each paired with the pressure frames around it.
  sync::TimelineConfig tc;
  tc.cameras = int(cameras.size());
  tc.camera_hz = 0;
  for (const auto& c : rig.cameras) {
    tc.camera_hz = std::max(tc.camera_hz, c.frame_rate);  // the grouping limit: half the fastest period
    tc.camera_latency_ns.push_back(c.latency_ns);
  }
  if (tc.camera_hz <= 0) tc.camera_hz = 60;
  tc.sample_hz = rig.store.video_fps > 0 ? rig.store.video_fps : tc.camera_hz;
  tc.anchor_ns = host0;
  tc.has_pressure = bool(sensel);
  if (rig.sensel) tc.pressure_latency_ns = rig.sensel->latency_ns;
  std::atomic<std::uint64_t> samples_stored{0};
  auto on_sample = [&](sync::SampleOut s) {
    SampleRecord r{s.index, s.tick, s.tick_ns, s.group.t_ns, s.group.span_ns, {}, {}, {}, {}};
    for (const auto& m : s.group.members)
      if (m) r.cameras.push_back({device_ids[std::size_t(m->stream)], m->connection, m->sequence, m->t_ns - s.group.t_ns});
    auto ref = [&](const std::optional<sync::FrameRef>& f) -> std::optional<SampleFrameRef> {
      if (!f) return std::nullopt;
      return SampleFrameRef{sensel_id, f->connection, f->sequence, f->t_ns - s.group.t_ns};
    };
    r.pressure = ref(s.pressure.nearest);
    r.pressure_before = ref(s.pressure.before);
    r.pressure_after = ref(s.pressure.after);
    writer.record(std::move(r));
    samples_stored.fetch_add(1, std::memory_order_relaxed);
  };
  auto on_clock = [&](sync::ClockSnapshot c) {
    const bool is_pressure = c.stream < 0;
    writer.record(ClockModelRecord{is_pressure ? sensel_id : device_ids[std::size_t(c.stream)], c.host_ns, c.segment,
                                   c.fit.x0, c.fit.offset_ns, c.fit.skew, c.latency_ns, c.probed ? "latch" : "arrivals",
                                   c.pairs, c.envelope_points, c.residual_p50_ns, c.residual_p99_ns});
  };
  sync::SessionTimeline timeline(tc, on_sample, on_clock);
  TimelineEnd timeline_end;
  timeline_end.feeding.store(int(cameras.size()));

  std::vector<std::thread> workers;
  for (std::size_t i = 0; i < cameras.size(); ++i)
    workers.emplace_back(camera_worker, std::ref(*cameras[i]), int(i), device_ids[i], std::ref(writer),
                         std::ref(*tallies[i]), std::ref(timeline), std::ref(timeline_end),
                         std::size_t(rig.store.queue_frames));
  std::string end_reason = "stopped by operator";
  bool start_failed = false;
  for (auto& cam : cameras) {
    if (Status s = cam->start(); !s.ok()) {
      spdlog::error("{}; stopping: every camera of the rig must record", s.error().message);
      end_reason = "a camera failed to start: " + s.error().message;
      start_failed = true;
      break;
    }
  }
  if (sensel && !start_failed) {
    if (Status s = sensel->start(writer, sensel_id, timeline); !s.ok()) {
      spdlog::error("Sensel: {}; stopping", s.error().message);
      end_reason = "the Sensel failed to start: " + s.error().message;
      start_failed = true;
    }
  }
  const std::int64_t rec_start = host_now().ns;
  auto last_progress = std::chrono::steady_clock::now();
  std::vector<bool> warned_encoder(cameras.size(), false);
  while (!start_failed) {
    std::this_thread::sleep_for(100ms);
    const double elapsed = double(host_now().ns - rec_start) / 1e9;
    if (stop_requested.load()) break;
    if (options.duration_s && elapsed >= *options.duration_s) {
      end_reason = "duration reached";
      break;
    }
    if (auto failure = writer.failure()) {
      spdlog::error("storage failed, stopping capture (everything written so far is kept): {}", *failure);
      end_reason = "storage failure: " + *failure;
      break;
    }
    // A camera whose encoder falls behind loses frames for the rest of the session unless the
    // operator acts: say so once, with what to change, rather than only count it.
    for (std::size_t i = 0; i < cameras.size(); ++i)
      if (!warned_encoder[i] && tallies[i]->encoder_behind.load() > 0) {
        warned_encoder[i] = true;
        spdlog::warn("{}: the video encoder cannot keep up, frames are being dropped (counted as encoder_behind). "
                     "This PC has {} cores for {} camera{} at crf {} preset {}: raise store.crf or lower "
                     "store.video_fps in the rig file, or record on a PC with more cores "
                     "(docs/PERFORMANCE.md, Store)",
                     rig.cameras[i].name, std::thread::hardware_concurrency(), cameras.size(),
                     cameras.size() == 1 ? "" : "s", rig.store.crf,
                     rig.store.preset);
      }
    if (std::chrono::steady_clock::now() - last_progress >= 2s) {
      last_progress = std::chrono::steady_clock::now();
      std::string line = fmt::format("{:6.1f} s", elapsed);
      for (std::size_t i = 0; i < cameras.size(); ++i) {
        const auto& t = *tallies[i];
        line += fmt::format(" | {} {} rx, {} video, {} lost", rig.cameras[i].name, t.received.load(),
                            writer.camera_stats(device_ids[i]).frames_in_video,
                            t.not_received.load() + t.incomplete.load() + t.encoder_behind.load());
      }
      if (sensel) line += fmt::format(" | sensel {} frames", sensel->stored());
      line += fmt::format(" | {} samples", samples_stored.load());
      spdlog::info("{}", line);
    }
  }

  const double recorded_s = double(host_now().ns - rec_start) / 1e9;
  // All cameras stop at once; one blocked on a reconnect attempt must not keep the others recording.
  for (auto& cam : cameras) cam->request_stop();
  if (sensel) sensel->stop();
  for (auto& cam : cameras) cam->stop();
  for (auto& w : workers) w.join();
  // At close: every frame re-mapped with its stream's final clock fit, every sample re-paired.
  writer.set_finalizer([&, clocks = timeline.final_clocks()](SessionIndex& index) {
    const auto r = realign(index, {clocks, device_ids, sensel_id, tc.pressure_max_offset_ns});
    spdlog::info("timeline: {} samples re-paired with the final clock fits", r.samples);
  });
  const auto tl = timeline.counts();
  writer.add_timeline_count("samples", tl.samples);
  writer.add_timeline_count("groups_complete", tl.groups_complete);
  writer.add_timeline_count("groups_incomplete", tl.groups_incomplete);
  writer.add_timeline_count("camera_frames_late_for_their_instant", tl.late_camera_frames);
  writer.add_timeline_count("ticks_without_a_group", tl.missed_ticks);
  for (const auto& [why, n] : tl.unpaired) writer.add_timeline_count("unpaired: " + why, n);
  for (std::size_t i = 0; i < tl.clock_resets.size(); ++i)
    if (tl.clock_resets[i])
      writer.add_timeline_count(
          fmt::format("clock_resets: {}", i < cameras.size() ? rig.cameras[i].name : std::string("sensel")),
          std::uint64_t(tl.clock_resets[i]));
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    const StreamCounters c = cameras[i]->counters();
    writer.add_stream_stats({device_ids[i], c.completed, c.failures, c.underruns, c.resent_packets, c.missing_packets,
                             c.queue_overflows});
  }
  sim.reset();
  if (!truth_tmp.empty()) {
    std::error_code ec;
    std::filesystem::rename(truth_tmp, writer.dir() / "sim-truth", ec);
    if (ec) spdlog::warn("simulator ground truth stays in {}: {}", truth_tmp.string(), ec.message());
  }
  const Status closed = writer.close(end_reason);

  // The report the operator reads, also kept in the session folder as report.txt.
  fmt::memory_buffer report;
  auto out = std::back_inserter(report);
  fmt::format_to(out, "session: {}\n", writer.dir().string());
  fmt::format_to(out, "ended: {} after {:.1f} s\n", end_reason, recorded_s);
  fmt::format_to(out, "{:<8} {:>9} {:>9} {:>9} {:>11} {:>12} {:>10} {:>9}\n", "camera", "received", "good", "in video",
             "incomplete", "not received", "enc. behind", "lost conn");
  bool any_loss = false;
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    const auto& t = *tallies[i];
    const auto st = writer.camera_stats(device_ids[i]);
    fmt::format_to(out, "{:<8} {:>9} {:>9} {:>9} {:>11} {:>12} {:>10} {:>9}\n", rig.cameras[i].name, t.received.load(),
               t.good.load(), st.frames_in_video, t.incomplete.load(), t.not_received.load(),
               t.encoder_behind.load(), t.lost_events.load());
    any_loss |= t.incomplete.load() + t.not_received.load() + t.encoder_behind.load() + t.lost_events.load() > 0;
  }
  for (std::size_t i = 0; i < cameras.size(); ++i)
    if (const auto n = tallies[i]->unidentified.load())
      fmt::format_to(out, "{}: {} buffers arrived without their own frame id (reasons no_frame_id_*, stale_metadata_*, "
                 "duplicate_frame_id); the frames they were are counted as not received\n",
                 rig.cameras[i].name, n);
  if (sensel) {
    fmt::format_to(out, "{}\n", sensel->summary());
    any_loss |= sensel->lossy();
  }
  fmt::format_to(out, "samples: {} at {:g} Hz ({} groups complete, {} with a camera missing, {} ticks without any group)\n",
                 tl.samples, tc.sample_hz, tl.groups_complete, tl.groups_incomplete, tl.missed_ticks);
  if (tl.late_camera_frames)
    fmt::format_to(out, "{} camera frames came too late for their instant's group\n", tl.late_camera_frames);
  for (const auto& [why, n] : tl.unpaired) fmt::format_to(out, "{} samples without pressure: {}\n", n, why);
  for (std::size_t i = 0; i < tl.clock_resets.size(); ++i)
    if (tl.clock_resets[i])
      fmt::format_to(out, "{}: its clock was reset {} time(s); each started a new clock-model segment\n",
                     i < cameras.size() ? rig.cameras[i].name : std::string("sensel"), tl.clock_resets[i]);
  fmt::format_to(out, "video keeps one frame per camera per sample ({}); every received frame is in session.db with its reason\n",
                 rig.store.video_codec);
  if (any_loss) fmt::format_to(out, "frames were lost: see the drops and frames tables (reason column) in session.db\n");
  if (writer.index_records_lost() > 0) fmt::format_to(out, "WARNING: {} index records were lost\n", writer.index_records_lost());
  const std::string report_text = fmt::to_string(report);
  fmt::print("\n{}", report_text);
  std::ofstream(writer.dir() / "report.txt") << report_text;
  if (start_failed) return 1;
  if (!closed.ok()) {
    spdlog::error("{}", closed.error().message);
    return 1;
  }
  return 0;
}

}  // namespace pvcap
