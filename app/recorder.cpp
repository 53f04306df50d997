#include "app/recorder.h"

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "capture/aravis_camera.h"
#include "capture/pixel_format.h"
#include "capture/sensel_device.h"
#include "core/log.h"
#include "core/gap_tracker.h"
#include "core/sequence_unwrap.h"
#include "core/time.h"
#include "storage/session_writer.h"
#include "sync/grid_keeper.h"

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

void camera_worker(AravisCamera& camera, std::int64_t device_id, SessionWriter& writer, CameraTally& tally,
                   std::int64_t anchor_ns, double video_fps) {
  SequenceUnwrapper unwrap(16, /*zero_is_skipped=*/true);
  std::uint32_t connection = UINT32_MAX;
  GridKeeper keeper(anchor_ns, video_fps, camera.config().frame_rate);
  // A frame that times out incomplete is delivered after its successor: hold gaps open for a
  // second so such a frame is counted once, as what it is.
  auto report_gap = [&](const GapTracker::Gap& g) {
    tally.not_received.fetch_add(g.count, std::memory_order_relaxed);
    writer.record(DropRecord{device_id, connection, g.first, g.count, "not_received", g.noticed_ns});
  };
  GapTracker gaps(1'000'000'000, report_gap);
  auto& queue = camera.frames();
  while (!queue.closed_and_empty()) {
    auto frame = queue.pop_for(100ms);
    gaps.settle(host_now().ns);
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
                                "no_frame_id_" + frame->detail, {}, {}});
      continue;
    }
    const auto step = unwrap.next(frame->frame_id);
    FrameRecord rec{device_id, frame->connection, step.sequence, frame->frame_id, frame->device_ts.ns,
                    frame->host_ts.ns, frame->aravis_system_ns, to_string(frame->status), false, "", {}, {}};
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
    } else if (!keeper.keep(frame->host_ts.ns)) {
      tally.good.fetch_add(1, std::memory_order_relaxed);
      rec.reason = "subsampled";
    } else {
      tally.good.fetch_add(1, std::memory_order_relaxed);
      cv::Mat bgr;
      if (Status s = to_bgr(frame->data, frame->size, frame->width, frame->height, frame->pixel_format, bgr); !s) {
        rec.reason = "unsupported_pixels: " + s.error().message;
      } else {
        frame->lease.reset();  // the camera gets its buffer back before we encode
        if (writer.submit_video(device_id, std::move(bgr), rec)) continue;  // the encoder records it
        tally.encoder_behind.fetch_add(1, std::memory_order_relaxed);
        rec.reason = "encoder_behind";
      }
    }
    writer.record(std::move(rec));
  }
  gaps.settle(0, /*flush_all=*/true);
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

  Status start(SessionWriter& writer, std::int64_t device_id) {
    writer_ = &writer;
    device_id_ = device_id;
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
      writer.record(PressureRecord{device_id_, 0, s->sequence, s->lost_before, s->device_ts.ns, s->host_ts.ns,
                                     s->host_wait_ns, s->grid.cols, s->grid.rows, s->grid.xscale, s->grid.yscale,
                                     std::move(s->payload)});
      stored_.fetch_add(1, std::memory_order_relaxed);
    }
  }

  SenselRigConfig config_;
  std::unique_ptr<sensel::SenselDevice> device_;
  std::atomic<SessionWriter*> writer_{nullptr};
  std::int64_t device_id_ = 0;
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

  std::vector<std::thread> workers;
  for (std::size_t i = 0; i < cameras.size(); ++i)
    workers.emplace_back(camera_worker, std::ref(*cameras[i]), device_ids[i], std::ref(writer), std::ref(*tallies[i]),
                         host0, rig.store.video_fps);
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
    if (Status s = sensel->start(writer, sensel_id); !s.ok()) {
      spdlog::error("Sensel: {}; stopping", s.error().message);
      end_reason = "the Sensel failed to start: " + s.error().message;
      start_failed = true;
    }
  }
  const std::int64_t rec_start = host_now().ns;
  auto last_progress = std::chrono::steady_clock::now();
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
      spdlog::info("{}", line);
    }
  }

  const double recorded_s = double(host_now().ns - rec_start) / 1e9;
  // All cameras stop at once; one blocked on a reconnect attempt must not keep the others recording.
  for (auto& cam : cameras) cam->request_stop();
  if (sensel) sensel->stop();
  for (auto& cam : cameras) cam->stop();
  for (auto& w : workers) w.join();
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
  fmt::format_to(out, "video keeps {} frames/s per camera ({}); every received frame is in session.db with its reason\n",
             rig.store.video_fps > 0 ? fmt::format("{:g}", rig.store.video_fps) : "all", rig.store.video_codec);
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
