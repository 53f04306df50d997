#include "session/recording.h"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "calib/rig_calibration.h"
#include "capture/aravis_camera.h"
#include "core/allocator.h"
#include "core/log.h"
#include "core/time.h"
#include "lighting/light_monitor.h"
#include "lighting/lighting_code.h"
#include "session/camera_pipeline.h"
#include "session/ptp_host_watch.h"
#include "session/realign.h"
#include "session/rig_lock.h"
#include "session/sample_record.h"
#include "storage/writer/session_writer.h"
#include "sync/session_timeline.h"

namespace pvcap::session {

using namespace std::chrono_literals;

namespace {


std::string settings_json(const CameraSettings& s, const CameraConfig& c) {
  nlohmann::json j = {{"pixel_format", s.pixel_format},
                      {"x", s.x},
                      {"y", s.y},
                      {"width", s.width},
                      {"height", s.height},
                      {"frame_rate", s.frame_rate},
                      {"exposure_us", s.exposure_us},
                      {"gain", s.gain},
                      {"gain_unit", s.gain_unit},
                      {"chunk_gain_unit", s.chunk_gain_unit},
                      {"trigger", s.trigger},
                      {"packet_size", s.packet_size},
                      {"payload", s.payload},
                      {"buffer_count", s.buffer_count},
                      {"timestamp_tick_hz", s.timestamp_tick_hz},
                      {"device_id", s.device_id},
                      {"features", s.features},
                      {"node_map_version", s.node_map_version},
                      {"chunks", s.chunks},
                      {"link_pacing", s.link_pacing},
                      {"feature_bag", s.feature_bag},
                      {"packet_resend", c.packet_resend},
                      {"socket_buffer_bytes", c.socket_buffer_bytes},
                      {"latency_ns", c.latency_ns},
                      {"timestamp_marks", to_string(c.timestamp_marks)},
                      {"stamp_to_mid_exposure_ns", stamp_to_mid_exposure_ns(c.timestamp_marks, s.exposure_us)}};
  return j.dump();
}

Status open_with_wait(AravisCamera& camera, double wait_s, const std::atomic<bool>& cancel) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(wait_s);
  for (;;) {
    Status s = camera.open();
    // A camera that answered and refused the rig file's settings is said at once, not after the wait.
    if (s.ok() || camera.refused() || cancel.load() || std::chrono::steady_clock::now() >= deadline) return s;
    std::this_thread::sleep_for(200ms);
  }
}

}  // namespace

Status check_sessions_root(const std::filesystem::path& root) {
  std::error_code ec;
  std::filesystem::create_directories(root, ec);
  if (ec) return Error{fmt::format("the sessions folder {} cannot be made: {}", root.string(), ec.message())};
  if (access(root.c_str(), W_OK) != 0)
    return Error{fmt::format("the sessions folder {} cannot be written: {}", root.string(), std::strerror(errno))};
  return {};
}

Recording::Recording() = default;

Recording::~Recording() {
  // A recording dropped without finish() (an exception in its owner) still stops its devices.
  if (state_.load() == kRecording || state_.load() == kStopping) (void)finish("ended abnormally");
}

Result<std::unique_ptr<Recording>> Recording::open(const RigConfig& rig, const RecordingOptions& options,
                                                   const std::atomic<bool>& cancel) {
  std::unique_ptr<Recording> r(new Recording());
  r->rig_ = rig;
  r->options_ = options;
  // The session starts at the sample grid's lattice point at or before now (sync::grid_lattice_floor):
  // its ticks then fall on the instants of any other session's, whole periods apart.
  const std::int64_t now_host = host_now().ns;
  r->host0_ = sync::grid_lattice_floor(now_host, sample_rate_hz(rig));
  r->wall0_ = wall_now_ns() - (now_host - r->host0_);
  // One rig, one recorder: before any device is touched.
  auto lock = RigLock::acquire(rig.source);
  if (!lock) return lock.error();
  r->rig_lock_ = std::move(lock.value());
  // The sessions folder can take a session: said before any device is opened.
  if (Status s = check_sessions_root(options.root); !s.ok()) return s.error();
  // A lighting the rig's lights cannot make: said before any device is opened.
  if (!rig.lights.empty() && options.conditions && !options.conditions->lighting.empty()) {
    lighting::LightNames names;
    for (const LightConfig& l : rig.lights) names.push_back(l.name);
    if (auto m = lighting::parse_lighting(options.conditions->lighting, names); !m)
      return Error{fmt::format("--lighting: {}", m.error().message)};
  }

  // A host out of PTP time: said before any device is opened (docs/multihost.md).
  if (rig.ptp && rig.ptp->host) {
    auto ptp = check_ptp_host(*rig.ptp);
    if (!ptp) return Error{fmt::format("{}\nno session was recorded", ptp.error().message)};
    spdlog::info("the host's PTP time: {}", sync::describe(ptp.value()));
  }

  // Every camera opened before anything is on disk: a rig that is not ready leaves no empty session.
  const std::size_t n = rig.cameras.size();
  r->device_ids_.assign(n, 0);
  r->warned_encoder_.assign(n, false);
  r->warned_spill_.assign(n, false);
  r->warned_behind_.assign(n, false);
  r->warned_foreign_.assign(n, false);
  r->pad_corners_px_.assign(n, std::nullopt);
  Recording* self = r.get();
  for (std::size_t i = 0; i < n; ++i) {
    r->tallies_.push_back(std::make_unique<CameraTally>());
    r->previews_.push_back(std::make_unique<Preview>());
    auto on_event = [self, i](const CameraEvent& e) {
      const bool lost = e.kind == CameraEvent::Kind::Lost;
      if (e.kind == CameraEvent::Kind::PtpReading || e.kind == CameraEvent::Kind::PtpOutOfLock) {
        // A second's PTP reading: stored, not logged (its changes come as State events).
        if (RecordingStore* w = self->events_writer_.load())
          w->record(EventRecord{e.at.ns,
                                e.kind == CameraEvent::Kind::PtpReading ? "ptp_camera_state" : "ptp_camera_out_of_lock",
                                self->device_ids_[i], e.message});
        return;
      }
      if (lost) {
        spdlog::error("{}", e.message);
        self->tallies_[i]->lost_events.fetch_add(1);
      } else if (e.kind == CameraEvent::Kind::State) {
        spdlog::info("{}", e.message);
      } else {
        spdlog::warn("{}", e.message);
      }
      const char* kind = lost                                     ? "camera_lost"
                         : e.kind == CameraEvent::Kind::NoTrigger ? "camera_no_trigger"
                         : e.kind == CameraEvent::Kind::State     ? "camera_state"
                                                                  : "camera_reconnected";
      if (RecordingStore* w = self->events_writer_.load())
        w->record(EventRecord{e.at.ns, kind, self->device_ids_[i], e.message});
    };
    r->cameras_.push_back(std::make_unique<AravisCamera>(int(i), rig.cameras[i], on_event));
  }
  for (auto& cam : r->cameras_)
    if (Status s = open_with_wait(*cam, options.device_wait_s, cancel); !s.ok())
      return Error{fmt::format("{}\nno session was recorded: every camera of {} must be ready", s.error().message,
                               rig.source.string())};
  if (rig.ptp && rig.ptp->cameras)
    if (Status s = wait_for_ptp_lock(r->cameras_, *rig.ptp, cancel); !s.ok())
      return Error{fmt::format("{}\nno session was recorded: every camera of {} must be locked to PTP time",
                               s.error().message, rig.source.string())};
  if (rig.sensel) {
    SenselPipelineOptions so;
    so.ports_dir = options.sensel_ports_dir;
    so.wait_s = std::max(2.0, options.device_wait_s);
    if (options.faults.sensel_queue_frames) so.queue_frames = *options.faults.sensel_queue_frames;
    so.stall = options.faults.sensel_pipeline_stall;
    auto opened = SenselPipeline::open(*rig.sensel, so, cancel);
    if (!opened)
      return Error{fmt::format("{}\nno session was recorded: the Sensel of {} must be ready", opened.error().message,
                               rig.source.string())};
    r->sensel_ = std::move(opened.value());
  }
  return r;
}

// The rig calibration file beside the rig file (pvcap calibrate writes it), if there is one: each
// camera's entry goes into the session's calibrations table, so the session says which calibration
// it was recorded with. A broken file is a warning, not a reason to lose a session.
void Recording::record_rig_calibration(RecordingStore& writer) {
  if (rig_.source.empty()) return;
  const auto file = calib::default_calibration_path(rig_.source);
  if (!std::filesystem::exists(file)) return;
  auto loaded = calib::load_rig_calibration(file);
  if (!loaded) {
    spdlog::warn("{} (the session is recorded without it; fix it or calibrate again)", loaded.error().message);
    return;
  }
  for (std::size_t i = 0; i < rig_.cameras.size(); ++i) {
    const calib::CameraCalibration* c = loaded.value().camera(rig_.cameras[i].name);
    if (!c) continue;
    const calib::MeasuredBy& m = c->pad ? *c->pad : c->intrinsics ? *c->intrinsics : calib::MeasuredBy{"unknown"};
    if (c->pad_corners_px) {  // the light meter reads off the pad (lighting/light_meter.h)
      std::array<lighting::Point, 4> q{};
      for (std::size_t k = 0; k < 4; ++k) q[k] = {(*c->pad_corners_px)[k].x, (*c->pad_corners_px)[k].y};
      pad_corners_px_[i] = q;
    }
    const cv::Matx33d h = c->cells_to_ideal.value_or(cv::Matx33d::zeros());
    nlohmann::json details = *c;
    details["calibration_file"] = std::filesystem::absolute(file).string();
    auto added = writer.add_calibration({device_ids_[i], m.created_wall_ns, m.method,
                                         nlohmann::json(std::vector<double>(h.val, h.val + 9)).dump(), m.rms_px,
                                         m.rms_mm, details.dump()});
    if (!added)
      spdlog::warn("{}: calibration not recorded in the session: {}", rig_.cameras[i].name, added.error().message);
  }
  spdlog::info("calibration: {} (recorded in the session)", file.string());
}

Result<std::unique_ptr<RecordingStore>> Recording::make_store() const {
  if (options_.make_store) return options_.make_store(rig_, wall0_, host0_);
  WriterOptions writer_options;
  if (options_.faults.index_queue_records) writer_options.index_queue_records = *options_.faults.index_queue_records;
  if (options_.faults.index_overflow_memory_records)
    writer_options.index_overflow_memory_records = *options_.faults.index_overflow_memory_records;
  writer_options.index_stall = options_.faults.index_writer_stall;
  writer_options.encoder_frame_delay = options_.faults.encoder_frame_delay;
  writer_options.encoder_stall = options_.faults.encoder_stall;
  auto created = SessionWriter::create(options_.root, rig_, wall0_, host0_, writer_options);
  if (!created) return created.error();
  return std::unique_ptr<RecordingStore>(std::move(created.value()));
}

Status Recording::start() {
  auto made = make_store();
  if (!made) return made.error();
  writer_ = std::move(made.value());
  RecordingStore& writer = *writer_;
  log::add_session_file(writer.dir());
  rig_lock_->set_session(writer.dir());
  spdlog::info("recording session {}", writer.dir().string());
  auto fail = [&](const Error& e) -> Status {
    (void)writer.close("failed to start");
    log::remove_session_file();
    return e;
  };
  for (std::size_t i = 0; i < cameras_.size(); ++i) {
    const CameraSettings s = cameras_[i]->settings();
    DeviceRecord d{"camera",   rig_.cameras[i].name,
                   s.vendor,   s.model,
                   s.serial,   s.address,
                   s.firmware, settings_json(s, rig_.cameras[i])};
    auto id = writer.add_camera(d, s.width, s.height, s.pixel_format);
    if (!id) return fail(id.error());
    device_ids_[i] = id.value();
  }
  for (Status s : {options_.participant ? writer.set_participant(*options_.participant) : Status{},
                   options_.conditions ? writer.set_conditions(*options_.conditions) : Status{}})
    if (!s.ok()) return fail(s.error());
  if (sensel_) {
    auto id = writer.add_device(sensel_->device_record());
    if (!id) return fail(id.error());
    sensel_id_ = id.value();
  }
  record_rig_calibration(writer);
  events_writer_.store(&writer);
  writer.start();
  if (options_.board_session)
    writer.record(EventRecord{host_now().ns, "board_session", std::nullopt,
                              "a calibration board session (for pvcap calibrate intrinsics)"});

  // The timeline: every stream on this host's clock, camera frames grouped by instant, one group per
  // tick of the sample grid, each paired with the pressure frames around it.
  sync::TimelineConfig tc;
  tc.cameras = int(cameras_.size());
  tc.camera_hz = grouping_rate_hz(rig_);  // the grouping limit: half the fastest period
  for (std::size_t i = 0; i < cameras_.size(); ++i) {
    tc.camera_latency_ns.push_back(rig_.cameras[i].latency_ns);
    // From the exposure the camera reads back, not the one asked (it may round).
    tc.camera_stamp_to_instant_ns.push_back(
        stamp_to_mid_exposure_ns(rig_.cameras[i].timestamp_marks, cameras_[i]->settings().exposure_us));
  }
  tc.sample_hz = sample_rate_hz(rig_);
  tc.anchor_ns = host0_;
  tc.has_pressure = bool(sensel_);
  if (rig_.sensel) tc.pressure_latency_ns = rig_.sensel->latency_ns;
  sample_hz_ = tc.sample_hz;
  pressure_max_offset_ns_ = tc.pressure_max_offset_ns;
  auto on_sample = [this](sync::SampleOut s) {
    std::vector<MappedCameraFrame> cameras;
    for (const auto& m : s.group.members)
      if (m) cameras.push_back({device_ids_[std::size_t(m->stream)], m->connection, m->sequence, m->t_ns});
    SampleRecord r =
        sample_record(s.index, s.tick, s.tick_ns, {s.group.t_ns, s.group.span_ns}, cameras, s.pressure, sensel_id_);
    if (r.pressure) {
      std::lock_guard lock(mu_);
      recent_offsets_ms_.push_back(std::abs(double(r.pressure->offset_ns)) / 1e6);
      if (recent_offsets_ms_.size() > 60) recent_offsets_ms_.pop_front();
    }
    writer_->record(std::move(r));
    samples_.fetch_add(1, std::memory_order_relaxed);
  };
  auto on_clock = [this](sync::ClockSnapshot c) {
    writer_->record(clock_record(c.stream < 0 ? sensel_id_ : device_ids_[std::size_t(c.stream)], c));
  };
  timeline_ = std::make_unique<sync::SessionTimeline>(tc, on_sample, on_clock);
  timeline_end_ = std::make_unique<TimelineEnd>(cameras_.size());
  timeline_end_->feeding.store(int(cameras_.size()));
  start_camera_workers(writer);
  // Every camera's stream settled first (a new stream waits before it takes frames), so the cameras
  // start together. The Sensel starts before them and stops after them (finish): pressure brackets
  // every camera frame, so the first and last samples have their pressure frames however long a
  // device takes to start or stop on a loaded machine (started after the cameras, a slow Sensel
  // start once left a full run's first sample without pressure; stopped first, the cameras' last
  // frames could outlive the pressure).
  for (auto& cam : cameras_) cam->settle();
  state_.store(kRecording);
  rec_start_ = host_now().ns;
  if (rig_.ptp && rig_.ptp->host)
    ptp_watch_ = std::make_unique<PtpHostWatch>(*rig_.ptp, [this](const EventRecord& e) {
      if (RecordingStore* w = events_writer_.load()) w->record(e);
    });
  if (sensel_)
    if (Status s = sensel_->start(writer, sensel_id_, *timeline_); !s.ok()) {
      spdlog::error("Sensel: {}; stopping", s.error().message);
      start_failure_ = "the Sensel failed to start: " + s.error().message;
      request_stop(*start_failure_);
      return {};
    }
  for (auto& cam : cameras_)
    if (Status s = cam->start(); !s.ok()) {
      spdlog::error("{}; stopping: every camera of the rig must record", s.error().message);
      start_failure_ = "a camera failed to start: " + s.error().message;
      request_stop(*start_failure_);
      return {};
    }
  if (light_monitor_ && !options_.board_session) {
    // The light check, then the session's lighting (every light, unless --lighting says otherwise).
    run_light_check();
    std::string code = options_.conditions ? options_.conditions->lighting : "";
    if (code.empty())
      for (const LightConfig& l : rig_.lights) code += l.name;
    light_thread_running_.store(true);
    light_thread_ = std::thread([this] { confirm_switches(); });
    if (!set_lighting(code)) warn(fmt::format("the lights could not be switched to {} (the log says why)", code));
  }
  return {};
}

void Recording::start_camera_workers(RecordingStore& writer) {
  workers_warmed_ = std::make_unique<std::latch>(std::ptrdiff_t(cameras_.size()));
  if (!rig_.lights.empty())
    light_monitor_ = std::make_unique<lighting::LightMonitor>(cameras_.size() * lighting::kMeterRegions);
  for (std::size_t i = 0; i < cameras_.size(); ++i)
    workers_.emplace_back(
        run_camera_pipeline,
        CameraPipeline{*cameras_[i], int(i), device_ids_[i], writer, *tallies_[i], *timeline_, *timeline_end_,
                       std::size_t(rig_.store.queue_frames), *previews_[i],
                       int(i) == options_.faults.stall_camera ? options_.faults.camera_pipeline_stall : std::nullopt,
                       workers_warmed_.get(), light_monitor_.get(), pad_corners_px_[i]});
  // The workers write their buffers before the first frame comes (camera_pipeline.cpp, warm_up): a
  // fraction of a second here rather than page faults in the first second's frames. Bounded, so a
  // slower machine still starts.
  for (const auto give_up = std::chrono::steady_clock::now() + 3s;
       !workers_warmed_->try_wait() && std::chrono::steady_clock::now() < give_up;)
    std::this_thread::sleep_for(5ms);
}

void Recording::request_stop(std::string reason) {
  std::lock_guard lock(mu_);
  if (stop_requested_.load()) return;
  stop_reason_ = std::move(reason);
  stop_requested_.store(true);
}

std::string Recording::wait(const std::atomic<bool>& interrupt, std::optional<double> duration_s) {
  auto last_progress = std::chrono::steady_clock::now();
  for (;;) {
    if (stop_requested_.load()) {
      std::lock_guard lock(mu_);
      return stop_reason_;
    }
    const double elapsed = double(host_now().ns - rec_start_) / 1e9;
    if (interrupt.load()) return "stopped by operator";
    if (duration_s && elapsed >= *duration_s) return "duration reached";
    if (auto failure = writer_->failure()) {
      spdlog::error("storage failed, stopping capture (everything written so far is kept): {}", *failure);
      return "storage failure: " + *failure;
    }
    warn_of_losses();
    if (std::chrono::steady_clock::now() - last_progress >= 2s) {
      last_progress = std::chrono::steady_clock::now();
      log_progress(elapsed);
      return_free_memory();  // so a long session's memory stays flat (core/allocator.h)
    }
    std::this_thread::sleep_for(100ms);
  }
}

void Recording::log_progress(double elapsed_s) {
  std::string line = fmt::format("{:6.1f} s", elapsed_s);
  for (std::size_t i = 0; i < cameras_.size(); ++i) {
    const auto& t = *tallies_[i];
    line +=
        fmt::format(" | {} {} rx, {} video, {} lost", rig_.cameras[i].name, t.received.load(),
                    writer_->camera_stats(device_ids_[i]).frames_in_video,
                    t.not_received.load() + t.buffer_underrun.load() + t.incomplete.load() + t.encoder_behind.load());
  }
  if (sensel_) line += fmt::format(" | sensel {} frames", sensel_->stored());
  line += fmt::format(" | {} samples", samples_.load());
  spdlog::info("{}", line);
}

void Recording::warn(std::string message) {
  spdlog::warn("{}", message);
  std::lock_guard lock(mu_);
  warnings_.push_back(std::move(message));
  if (warnings_.size() > 8) warnings_.pop_front();
}

bool Recording::post(ProtocolEventRecord event) {
  if (state_.load() != kRecording || !writer_) return false;
  if (event.host_ns == 0) event.host_ns = host_now().ns;
  return writer_->record_committed(std::move(event), 2s);
}

bool Recording::note(std::string text) {
  if (state_.load() != kRecording || !writer_) return false;
  return writer_->record_committed(OperatorNoteRecord{host_now().ns, std::move(text)}, 2s);
}

std::filesystem::path Recording::dir() const { return writer_ ? writer_->dir() : std::filesystem::path(); }

RecordingResult Recording::finish(const std::string& end_reason) {
  RecordingResult result;
  if (state_.load() != kRecording) {
    result.exit_code = 1;
    return result;
  }
  stop_light_thread();  // its last confirmations are committed before the store closes
  std::optional<PtpHostTally> ptp;
  if (ptp_watch_) {
    ptp = ptp_watch_->tally();
    ptp_watch_.reset();  // its last reading stored before the store closes
  }
  state_.store(kStopping);
  RecordingStore& writer = *writer_;
  result.recorded_s = double(host_now().ns - rec_start_) / 1e9;
  if (timeline_end_) timeline_end_->stopping.store(true);
  // All cameras stop at once; one blocked on a reconnect attempt must not keep the others recording.
  for (auto& cam : cameras_) cam->request_stop();
  for (std::size_t i = 0; i < cameras_.size(); ++i) {
    cameras_[i]->stop();
    // A test's fault: a camera slow to answer its stop holds the others' stops back.
    if (i == 0 && options_.faults.camera_stop_stall_s > 0)
      std::this_thread::sleep_for(std::chrono::duration<double>(options_.faults.camera_stop_stall_s));
  }
  if (sensel_) sensel_->stop();  // last: its pressure covers the cameras' last frames (start() says why)
  for (auto& w : workers_) w.join();
  workers_.clear();
  // Only now: a camera's stream lives until its last frame buffer comes back from the workers, and
  // on going it tells its device to stop sending, waiting 500 ms a try for an answer. Before the
  // workers had drained, a simulator stopped here turned a short session's close into 8 s of those
  // waits (four cameras, their streams still held by the start's backlog).
  if (options_.on_devices_stopped) options_.on_devices_stopped();
  // At close: every frame re-mapped with its stream's final clock fit, every sample re-paired,
  // from the fits the store holds (each stream's final one written now), in committed steps.
  timeline_->final_snapshots();
  writer.set_finalizer([max_offset_ns = pressure_max_offset_ns_,
                        limit = sync::Grouper::limit_for(grouping_rate_hz(rig_)),
                        stall_s = options_.faults.realign_stall_s](SessionIndex& index) {
    spdlog::info("timeline: re-mapping every frame with the final clock fits");
    // Its steps said as they are committed; a test's fault (realign.stall_s) holds it open after the first.
    auto step = [stall_s](const std::string& line) {
      spdlog::info("{}", line);
      if (stall_s > 0 && line.rfind("re-mapping:", 0) == 0)
        std::this_thread::sleep_for(std::chrono::duration<double>(stall_s));
    };
    const auto r = realign(index, {max_offset_ns, 2000, step, limit});
    spdlog::info("timeline: {} samples re-paired with the final clock fits in {:.1f} s", r.samples, r.seconds);
    if (const std::string warning = r.many_left_warning(); !warning.empty()) spdlog::warn("timeline: {}", warning);
  });
  const auto tl = timeline_->counts();
  writer.add_timeline_count("samples", tl.samples);
  writer.add_timeline_count("groups_complete", tl.groups_complete);
  writer.add_timeline_count("groups_incomplete", tl.groups_incomplete);
  writer.add_timeline_count("camera_frames_late_for_their_instant", tl.late_camera_frames);
  writer.add_timeline_count("ticks_without_a_group", tl.missed_ticks);
  for (const auto& [why, n] : tl.unpaired) writer.add_timeline_count("unpaired: " + why, n);
  for (std::size_t i = 0; i < cameras_.size(); ++i)
    if (const auto late = tallies_[i]->arrivals_late.load(); late > 0) {
      // Rare by design (the stream thread stamps a buffer microseconds after queueing it); counted,
      // since such a frame's arrival carries the worker's delay into the clock fit's arrivals.
      writer.add_timeline_count(fmt::format("camera_arrivals_stamped_late: {}", rig_.cameras[i].name), late);
      spdlog::warn("{}: {} frames' arrival is the moment pvcap took them (their stamp came more than 2 ms late)",
                   rig_.cameras[i].name, late);
    }
  for (std::size_t i = 0; i < tl.clock_resets.size(); ++i)
    if (tl.clock_resets[i])
      writer.add_timeline_count(
          fmt::format("clock_resets: {}", i < cameras_.size() ? rig_.cameras[i].name : std::string("sensel")),
          std::uint64_t(tl.clock_resets[i]));
  for (std::size_t i = 0; i < cameras_.size(); ++i) {
    const StreamCounters c = cameras_[i]->counters();
    writer.add_stream_stats(
        {device_ids_[i], c.completed, c.failures, c.underruns, c.resent_packets, c.missing_packets, c.queue_overflows});
  }
  events_writer_.store(nullptr);
  const Status closed = writer.close(end_reason);
  state_.store(kEnded);
  result.dir = writer.dir();

  if (ptp)
    result.notes.push_back(
        ptp->seconds_out_of_time == 0
            ? fmt::format("host PTP time: in time at each of {} readings (grandmaster {}, worst offset {:.0f} ns)",
                          ptp->readings, ptp->grandmaster, ptp->worst_offset_ns)
            : fmt::format("WARNING: host PTP time: out of time for {} s ({} answers read from ptp4l; the last "
                          "problem: {}); the session's ptp_host_out_of_time events say when",
                          ptp->seconds_out_of_time, ptp->readings, ptp->last_problem));
  if (writer.index_records_lost() > 0)
    result.notes.push_back(fmt::format("WARNING: {} index records were lost ({})", writer.index_records_lost(),
                                       writer.index_records_lost_by_kind()));
  log::remove_session_file();
  if (start_failure_) result.exit_code = 1;
  if (!closed.ok()) {
    spdlog::error("{}", closed.error().message);
    result.exit_code = 1;
  }
  return result;
}

}  // namespace pvcap::session
