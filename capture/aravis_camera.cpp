#include "capture/aravis_camera.h"
#include "capture/aravis_camera_link.h"
#include "capture/aravis_features.h"

#include "capture/aravis_handles.h"
#include "capture/aravis_stream.h"
#include "capture/camera_watchdog.h"
#include "capture/genicam_features.h"
#include "capture/gvcp_ping.h"
#include "codec/pixel_format.h"
#include "core/thread_name.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <fstream>
#include <utility>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

namespace pvcap {

// The codec target names pixel formats by their PFNC codes without Aravis: the same numbers.
static_assert(pfnc::kMono8 == ARV_PIXEL_FORMAT_MONO_8 && pfnc::kRGB8 == ARV_PIXEL_FORMAT_RGB_8_PACKED &&
              pfnc::kBayerGR8 == ARV_PIXEL_FORMAT_BAYER_GR_8 && pfnc::kBayerRG8 == ARV_PIXEL_FORMAT_BAYER_RG_8 &&
              pfnc::kBayerGB8 == ARV_PIXEL_FORMAT_BAYER_GB_8 && pfnc::kBayerBG8 == ARV_PIXEL_FORMAT_BAYER_BG_8 &&
              pfnc::kBayerGR12 == ARV_PIXEL_FORMAT_BAYER_GR_12 && pfnc::kBayerRG12 == ARV_PIXEL_FORMAT_BAYER_RG_12 &&
              pfnc::kBayerGB12 == ARV_PIXEL_FORMAT_BAYER_GB_12 && pfnc::kBayerBG12 == ARV_PIXEL_FORMAT_BAYER_BG_12);

using namespace std::chrono_literals;

namespace {
// GVSP overhead on top of the pixels: IP/UDP/GVSP headers per ~1500-byte packet.
constexpr double kProtocolOverhead = 1.03;

// How many cameras of this process are acquiring now. A stream made while any is (a reconnection, a
// camera that answered late) takes its packets on a UDP port of its own, never a packet socket: its
// window before the filter would let another camera's frames in (StreamSocket).
std::atomic<int> g_acquiring{0};

}  // namespace

long read_rmem_max() {
  std::ifstream in("/proc/sys/net/core/rmem_max");
  long v = 0;
  in >> v;
  return in ? v : 0;
}

LinkPacing link_pacing(std::size_t packet_bytes, double link_mbps, int link_cameras) {
  const double link_bits_per_s = link_mbps * 1e6, n = std::max(1, link_cameras);
  // A packet takes P*8/L on the wire; at a share of L/n it may leave every P*8*n/L: the rest is the gap.
  return {link_bits_per_s / 8.0 / n, double(packet_bytes) * 8.0 * (n - 1) / link_bits_per_s};
}

std::size_t buffer_count_for(const CameraConfig& config) {
  if (config.buffer_count > 0) return std::size_t(config.buffer_count);
  return std::max<std::size_t>(8, std::size_t(std::ceil(config.frame_rate * 0.5)));
}

Status preflight(const std::string& label, const LinkBudget& b) {
  const double mbps = double(b.payload_bytes) * 8.0 * b.frame_rate * kProtocolOverhead / 1e6;
  if (b.link_cameras > 1 && mbps * b.link_cameras > b.link_mbps)
    return Error{fmt::format(
        "{}: {} cameras share link '{}' ({:.0f} Mbit/s), and each needs {:.0f} Mbit/s ({} bytes per frame at {:.1f} "
        "fps): {:.0f} in all. Lower frame_rate, crop width/height, or give some of them another link",
        label, b.link_cameras, b.link, b.link_mbps, mbps, b.payload_bytes, b.frame_rate, mbps * b.link_cameras)};
  if (mbps > b.link_mbps)
    return Error{
        fmt::format("{}: {} bytes per frame at {:.1f} fps needs {:.0f} Mbit/s, more than its {:.0f} Mbit/s link: lower "
                    "frame_rate, crop width/height, or set link_mbps if the link is faster",
                    label, b.payload_bytes, b.frame_rate, mbps, b.link_mbps)};
  if (b.socket_buffer_bytes > 0 && b.rmem_max > 0 && b.socket_buffer_bytes > b.rmem_max)
    return Error{
        fmt::format("{}: socket_buffer_bytes {} is above the kernel limit net.core.rmem_max = {}; raise the limit "
                    "(sysctl -w net.core.rmem_max={}) or lower socket_buffer_bytes",
                    label, b.socket_buffer_bytes, b.rmem_max, b.socket_buffer_bytes)};
  return {};
}

AravisCamera::AravisCamera(int index, CameraConfig config, EventHandler on_event)
    : index_(index), config_(std::move(config)), on_event_(std::move(on_event)), link_(std::make_unique<Link>()) {
  arv::route_glib_logs_to_spdlog();
}

AravisCamera::~AravisCamera() { stop(); }

std::string AravisCamera::label() const {
  std::string where;
  if (!config_.serial.empty()) where += "serial " + config_.serial;
  if (!config_.address.empty()) where += (where.empty() ? "at " : " at ") + config_.address;
  return fmt::format("{} ({})", config_.name, where);
}

std::chrono::milliseconds AravisCamera::stall_timeout() const {
  const auto ten_periods = std::chrono::milliseconds(std::int64_t(10'000.0 / config_.frame_rate));
  return std::max<std::chrono::milliseconds>(500ms, ten_periods);
}

CameraSettings AravisCamera::settings() const {
  std::lock_guard lock(mu_);
  return settings_;
}

StreamCounters AravisCamera::counters() const {
  std::lock_guard lock(mu_);
  StreamCounters total = past_counters_;
  if (link_->stream) total += link_->stream->counters();
  return total;
}

void AravisCamera::emit(CameraEvent::Kind kind, std::string message) {
  if (on_event_) on_event_(CameraEvent{index_, kind, host_now(), std::move(message)});
}

Status AravisCamera::connect_and_configure(std::uint32_t connection) {
  const std::string id = config_.address.empty() ? config_.serial : config_.address;
  arv::GErrorSlot err;
  arv::GPtr<ArvCamera> cam(arv_camera_new(id.c_str(), err.out()));
  if (!cam)
    return Error{
        fmt::format("{}: no camera answers ({}); check power, cabling and that it is on this subnet "
                    "(`pvcap devices` lists what answers)",
                    label(), err.message().empty() ? "not found" : err.message())};
  std::lock_guard lock(mu_);
  link_->camera = std::move(cam);
  if (!config_.serial.empty()) {
    const char* serial = arv_camera_get_device_serial_number(link_->camera.get(), nullptr);
    if (!serial || config_.serial != serial) {
      const std::string got = serial ? serial : "?";
      link_->camera.reset();
      return Error{fmt::format("{}: the camera at {} has serial {}, not {}", label(), id, got, config_.serial)};
    }
  }
  if (Status s = apply_features(); !s.ok()) {
    link_->camera.reset();
    refused_.store(true);  // it answered, and cannot record as asked: waiting will not change that
    return s;
  }
  const LinkBudget budget{settings_.payload, settings_.frame_rate, config_.link_mbps, config_.socket_buffer_bytes,
                          read_rmem_max(),   config_.link_cameras, config_.link};
  if (Status s = preflight(label(), budget); !s.ok()) {
    link_->camera.reset();
    refused_.store(true);
    return s;
  }
  // The pixel format each frame must carry: by its name where the codec knows it, else the code the
  // camera itself reads back (a vendor's own format still guards against another camera's frames).
  std::uint32_t format = pixel_format_code(settings_.pixel_format);
  if (format == 0) format = std::uint32_t(arv_camera_get_pixel_format(link_->camera.get(), nullptr));
  const ExpectedImage expected{settings_.width, settings_.height, format};
  const int others = g_acquiring.load();
  const StreamSocket socket = others > 0 ? StreamSocket::OwnPort : StreamSocket::Packet;
  if (socket == StreamSocket::OwnPort)
    spdlog::info("{}: {} other camera(s) streaming: this stream takes its packets on a UDP port of its own", label(),
                 others);
  auto stream = AravisStream::create(
      link_->camera.get(), index_, connection, settings_.payload, settings_.buffer_count, config_.packet_resend,
      config_.socket_buffer_bytes, losses_, expected,
      AravisChunks::create(link_->camera.get(), chunk_features_, config_.timestamp_marks, settings_.exposure_us),
      socket);
  if (!stream) {
    link_->camera.reset();
    return Error{fmt::format("{}: {}", label(), stream.error().message)};
  }
  link_->stream = std::move(stream.value());
  {
    std::lock_guard feed(feed_mu_);
    feed_ = link_->stream;
  }
  ArvDevice* dev = arv_camera_get_device(link_->camera.get());
  latch_command_.clear();
  latch_value_.clear();
  // The latch under whichever name the camera's node map uses (capture/genicam_features.h: SFNC 2's
  // TimestampLatch on FLIR Blackfly S and Basler ace 2, GevTimestampControlLatch on older cameras).
  const auto& features = settings_.features;
  if (features.count(role_key(CameraRole::TimestampLatch))) {
    latch_command_ = features.at(role_key(CameraRole::TimestampLatch));
    latch_value_ = features.at(role_key(CameraRole::TimestampLatchValue));
  }
  control_lost_.store(false);
  link_->control_lost_id = g_signal_connect(dev, "control-lost", G_CALLBACK(&Link::on_control_lost), this);
  return {};
}

Status AravisCamera::open() {
  refused_.store(false);
  Status s = connect_and_configure(connection_);
  if (s.ok()) {
    const CameraSettings st = settings();
    spdlog::info("{}: {} {} serial {} at {}, {} {}x{}+{}+{} @ {:.2f} fps, packet {} B, {} buffers of {} B", label(),
                 st.vendor, st.model, st.serial, st.address, st.pixel_format, st.width, st.height, st.x, st.y,
                 st.frame_rate, st.packet_size, st.buffer_count, st.payload);
    // A stream made again while other cameras stream receives on a UDP socket (StreamSocket), whose
    // buffer the kernel caps at rmem_max: under two frames, a reconnected camera would lose frames.
    if (const long rmem = read_rmem_max(); rmem > 0 && std::size_t(rmem) < 2 * st.payload)
      spdlog::warn(
          "{}: net.core.rmem_max is {} bytes, under two of its frames ({} bytes): after a reconnection its "
          "stream receives on a UDP socket capped there and may lose frames; raise it: sysctl -w "
          "net.core.rmem_max={}",
          label(), rmem, 2 * st.payload, 4 * st.payload);
    std::vector<std::string> used;
    for (const auto& [role, name] : st.features) used.push_back(role + " " + name);
    spdlog::info("{}: features (node map {}): {}", label(), st.node_map_version, fmt::join(used, ", "));
    if (has_timestamp_latch())
      spdlog::info("{}: has a timestamp latch: its clock is read directly, four times a second", label());
    else
      spdlog::info(
          "{}: no timestamp latch: its clock is mapped from frame arrivals (set latency_ns in the rig "
          "file to its exposure-to-leader latency)",
          label());
  }
  return s;
}

void AravisCamera::settle() {
  std::shared_ptr<AravisStream> stream;
  {
    std::lock_guard lock(mu_);
    stream = link_->stream;
  }
  if (stream) stream->accept_from_now();  // may wait a moment: not under the lock the probes and watchdog take
}

Status AravisCamera::start() {
  {
    std::lock_guard lock(mu_);
    if (!link_->camera) return Error{fmt::format("{}: start() before a successful open()", label())};
  }
  settle();
  {
    std::lock_guard lock(mu_);
    arv::GErrorSlot err;
    arv_camera_start_acquisition(link_->camera.get(), err.out());
    if (err) return Error{fmt::format("{}: AcquisitionStart failed: {}", label(), err.message())};
    if (!std::exchange(link_->acquiring, true)) g_acquiring.fetch_add(1);
  }
  started_at_ = host_now();
  // The first frames' instants come from this probe: mapped by their arrivals instead, they were 4-14
  // ms late on an idle machine (more when loaded) until the probe loop's first probe, a quarter second
  // on, and a sample chosen on that clock may take the other of a camera's two frames near its tick.
  probe_clock_at_start();
  running_.store(true);
  control_thread_ = std::thread([this] {
    name_this_thread("watch-" + config_.name);
    control_loop();
  });
  if (config_.trigger == TriggerMode::Software)
    trigger_thread_ = std::thread([this] {
      name_this_thread("trigger-" + config_.name);
      trigger_loop();
    });
  probe_thread_ = std::thread([this] {
    name_this_thread("probe-" + config_.name);
    probe_loop();
  });
  return {};
}

void AravisCamera::trigger_loop() {
  const auto period = std::chrono::nanoseconds(std::int64_t(1e9 / config_.frame_rate));
  auto next = std::chrono::steady_clock::now();
  while (running_.load()) {
    next += period;
    {
      std::unique_lock lock(wake_mu_);
      wake_.wait_until(lock, next, [&] { return !running_.load(); });
    }
    if (!running_.load()) break;
    std::lock_guard lock(mu_);
    // A lost camera is the watchdog's business.
    if (link_->camera) arv_camera_software_trigger(link_->camera.get(), nullptr);
    if (std::chrono::steady_clock::now() > next + period) next = std::chrono::steady_clock::now();  // no bursts
  }
}

void AravisCamera::teardown_connection(bool camera_reachable) {
  std::shared_ptr<AravisStream> stream;
  arv::GPtr<ArvCamera> camera;
  {
    std::lock_guard lock(mu_);
    stream = std::move(link_->stream);
    camera = std::move(link_->camera);
    if (stream) past_counters_ += stream->counters();
    if (std::exchange(link_->acquiring, false)) g_acquiring.fetch_sub(1);
  }
  if (stream) {
    std::lock_guard feed(feed_mu_);
    feed_.reset();
    retired_.push_back(stream);  // the consumer takes its last frames, then its last losses
  }
  if (camera && camera_reachable) arv_camera_stop_acquisition(camera.get(), nullptr);
  if (stream) stream->quiesce();
  if (stream && !camera_reachable) stream->device_unreachable();
  if (camera && link_->control_lost_id)
    g_signal_handler_disconnect(arv_camera_get_device(camera.get()), link_->control_lost_id);
  link_->control_lost_id = 0;
  // `stream` stays alive while frames leased from it are still queued or being encoded.
}

std::optional<CameraFrame> AravisCamera::next_frame(std::chrono::milliseconds timeout) {
  std::shared_ptr<AravisStream> stream;
  bool retired = false, stopped = false;
  {
    std::lock_guard feed(feed_mu_);
    retired = !retired_.empty();
    stream = retired ? retired_.front() : feed_;
    stopped = stopped_;
  }
  if (retired) {
    // A frame stamped before quiesce() may reach Aravis' queue a moment after its stamp (Aravis'
    // order varies): a short wait takes them all (bounded, so a stream that never delivers what
    // it stamped cannot hold the next connection's frames back).
    const auto until = std::chrono::steady_clock::now() + std::min<std::chrono::milliseconds>(timeout, 200ms);
    do {
      if (auto frame = stream->take_frame(std::chrono::milliseconds(1))) return frame;
    } while (!stream->drained() && std::chrono::steady_clock::now() < until);
    if (!stream->drained()) return std::nullopt;  // asked again on the next call
    stream->settle_losses(host_now(), /*all=*/true);
    std::lock_guard feed(feed_mu_);
    retired_.pop_front();
    return std::nullopt;
  }
  if (stream) return stream->take_frame(timeout);
  if (stopped) {
    if (!frames_done_.exchange(true)) losses_.close();
    return std::nullopt;
  }
  std::this_thread::sleep_for(std::min<std::chrono::milliseconds>(timeout, 20ms));  // between connections
  return std::nullopt;
}

void AravisCamera::control_loop() {
  CameraWatchdog::Config wc;
  wc.stall_timeout = stall_timeout();
  wc.first_frame_timeout = first_frame_timeout();
  wc.on_trigger_line = config_.trigger == TriggerMode::Hardware;
  // Asked over GVCP, so only a camera with an IPv4 address; another is left to Aravis' control-lost signal.
  wc.can_ask = is_ipv4(settings().address);
  CameraWatchdog watchdog(wc);
  watchdog.started(started_at_);
  bool connected = true;
  HostNs next_attempt{0};
  bool streaming = false;  // the last look found a frame within the last 100 ms
  while (running_.load()) {
    {
      std::unique_lock lock(wake_mu_);
      // While frames flow, two looks a second (each wake-up costs ~50 us of CPU here: docs/performance-log.md,
      // "Capture path"); once a camera is silent, or not connected, twenty, so a lost camera is named as
      // soon as the watchdog decides: a look at most 0.5 s after the last frame finds it silent (the
      // stall timeout is at least 0.5 s) and looks every 50 ms from then on. A stop and Aravis'
      // control-lost signal wake it at once.
      wake_.wait_for(lock, streaming ? 500ms : 50ms, [&] { return !running_.load() || control_lost_.load(); });
    }
    if (!running_.load()) break;
    const HostNs now = host_now();
    if (!connected) {
      if (now >= next_attempt) {
        next_attempt = HostNs{now.ns + 1'000'000'000};
        connected = reconnect();
        if (connected) watchdog.started(started_at_);
      }
      continue;
    }
    HostNs last{0};
    std::uint64_t underruns = 0;
    {
      std::lock_guard lock(mu_);
      if (link_->stream) {
        last = link_->stream->last_arrival();
        link_->stream->settle_losses(now);  // a silent camera's gaps too
        underruns = link_->stream->counters().underruns;
      }
    }
    streaming = last.ns != 0 && now.ns - last.ns < 100'000'000;
    const auto look = watchdog.look(now, last, underruns, control_lost_.load());
    if (look.verdict == CameraWatchdog::Verdict::Ask && watchdog.answered(gvcp_answers(settings().address, 250ms)))
      emit(CameraEvent::Kind::NoTrigger,
           fmt::format("{}: no frame for {} ms, but the camera answers: no trigger reaches it (check its trigger "
                       "cable and that the trigger source runs)",
                       label(), look.silent_ms));
    if (look.verdict == CameraWatchdog::Verdict::Lost) {
      emit(CameraEvent::Kind::Lost,
           fmt::format("{}: camera lost ({}) -- unplugged, powered off, or its link is down; the other cameras keep "
                       "recording, reconnecting every second",
                       label(), look.why));
      teardown_connection(false);
      connected = false;
      streaming = false;
      next_attempt = now;
    }
  }
  if (connected) teardown_connection(true);
}

bool AravisCamera::reconnect() {
  // Opening a camera that is not there holds this thread for Aravis' timeouts (2.5 s a try here),
  // and a stop waits for it: a camera that does not answer one read in 250 ms is not tried.
  if (is_ipv4(settings().address) && !gvcp_answers(settings().address, 250ms)) {
    spdlog::debug("{}: reconnect attempt: no answer from {}", label(), settings().address);
    return false;
  }
  Status s = connect_and_configure(++connection_);
  if (!s.ok()) {
    spdlog::debug("{}: reconnect attempt failed: {}", label(), s.error().message);
    return false;
  }
  arv::GErrorSlot err;
  settle();
  {
    std::lock_guard lock(mu_);
    if (link_->camera) arv_camera_start_acquisition(link_->camera.get(), err.out());
    if (link_->camera && !err && !std::exchange(link_->acquiring, true)) g_acquiring.fetch_add(1);
  }
  if (err) {
    teardown_connection(false);
    return false;
  }
  started_at_ = host_now();
  // One probe only: this is the watchdog's thread, and a camera gone again would hold it for GVCP's
  // timeouts (the probe loop takes the rest once frames flow).
  (void)probe_clock(/*at_start=*/true);
  emit(CameraEvent::Kind::Reconnected, fmt::format("{}: reconnected, recording again", label()));
  return true;
}

bool AravisCamera::has_timestamp_latch() const {
  std::lock_guard lock(mu_);
  return !latch_command_.empty();
}

// Reads the camera's clock: the value latched lies between the host's time just before the
// latch command and the time the new value was read back (a camera latches while it handles
// the command; one that latches later is waited for, briefly). Runs on its own thread: GVCP
// to a camera that just vanished blocks for its timeouts, and the watchdog must not wait.
void AravisCamera::probe_clock_at_start() {
  for (int attempt = 0; attempt < 5; ++attempt) {
    std::int64_t width = INT64_MAX;
    if (probe_clock(/*at_start=*/true, &width) == Probe::Taken && width <= 2'000'000) return;
  }
}

AravisCamera::Probe AravisCamera::probe_clock(bool at_start, std::int64_t* width_ns) {
  arv::GPtr<ArvCamera> cam;
  std::string command, value;
  double tick_hz = 1e9;
  std::uint32_t connection = 0;
  {
    std::lock_guard lock(mu_);
    if (!link_->camera || latch_command_.empty()) return Probe::NotStreaming;
    const HostNs last = link_->stream ? link_->stream->last_arrival() : HostNs{0};
    if (!at_start && (last.ns == 0 || host_now().ns - last.ns > 100'000'000)) return Probe::NotStreaming;
    cam.reset(ARV_CAMERA(g_object_ref(link_->camera.get())));
    command = latch_command_;
    value = latch_value_;
    if (settings_.timestamp_tick_hz) tick_hz = double(settings_.timestamp_tick_hz);
    connection = connection_.load();
  }
  ArvDevice* dev = arv_camera_get_device(cam.get());
  arv::GErrorSlot err;
  // What the latch holds now, so its new value can be told from it. The read also wakes the path
  // (the host's and the device's side) just before the command, so the bracket's two legs meet it
  // alike: without it the command met a path asleep since the last probe, the latch fell late in
  // its bracket, and the simulated cameras' mapped times were biased early by 0.01-0.105 ms
  // (0.05 at most with it, in six runs; docs/performance-log.md, "Capture path").
  const gint64 before = arv_device_get_integer_feature_value(dev, value.c_str(), err.out());
  if (err) return Probe::Failed;
  const HostNs lo = host_now();
  arv_device_execute_command(dev, command.c_str(), err.out());
  if (err) return Probe::Failed;
  // At the start a slow latch is waited for longer (20 ms): a wide bracket still bounds the first
  // frames' instants, no reading leaves them to their arrivals.
  for (int attempt = 0, attempts = at_start ? 100 : 20; attempt < attempts; ++attempt) {
    const gint64 ticks = arv_device_get_integer_feature_value(dev, value.c_str(), err.out());
    if (err) return Probe::Failed;
    if (ticks != before) {
      const HostNs hi = host_now();
      ClockProbe probe{connection, DeviceNs{std::int64_t(double(ticks) * (1e9 / tick_hz))}, lo, hi};
      (void)probes_.try_push(probe);  // a full queue (nobody reading) loses a probe, nothing else
      if (width_ns) *width_ns = hi.ns - lo.ns;
      return Probe::Taken;
    }
    std::this_thread::sleep_for(200us);
  }
  return Probe::Failed;  // the value never changed: a latch that does not work, or a slow one; try again later
}

void AravisCamera::probe_loop() {
  // Four probes a second for a connection's first 20 (its clock model converges on them), then one a
  // second: each costs GVCP round trips and wake-ups on both sides, and a converged model gains little
  // from more (docs/performance-log.md, "Capture path"). After a failure (a vanishing camera, a busy link)
  // a pause.
  constexpr int kFastProbes = 20;
  std::uint32_t connection = 0;
  int taken = 0;
  auto state_due = std::chrono::steady_clock::now();
  while (running_.load()) {
    if (const auto now = std::chrono::steady_clock::now(); now >= state_due) {
      state_due = now + 1s;
      watch_state();
    }
    const Probe p = probe_clock();
    if (const std::uint32_t now_on = connection_.load(); now_on != connection) {
      connection = now_on;  // a new connection starts a new clock segment: converge again
      taken = 0;
    }
    taken += p == Probe::Taken;
    const auto pause = p == Probe::Failed ? 2000ms : taken < kFastProbes ? 250ms : 1000ms;
    std::unique_lock lock(wake_mu_);
    wake_.wait_for(lock, pause, [&] { return !running_.load(); });
  }
}

void AravisCamera::watch_state() {
  arv::GPtr<ArvCamera> cam;
  std::string temperature, ptp;
  {
    std::lock_guard lock(mu_);
    if (!link_->camera) return;
    const auto& features = settings_.features;
    if (const auto t = features.find(role_key(CameraRole::DeviceTemperature)); t != features.end())
      temperature = t->second;
    if (const auto p = features.find(role_key(CameraRole::PtpStatus)); p != features.end()) ptp = p->second;
    if (temperature.empty() && ptp.empty() && !config_.ptp) return;
    cam.reset(ARV_CAMERA(g_object_ref(link_->camera.get())));
  }
  ArvDevice* dev = arv_camera_get_device(cam.get());
  if (config_.ptp) {  // its state a second, each reading an event (aravis_camera_ptp.cpp)
    AravisFeatures f(dev);
    watch_ptp(f);
    ptp.clear();  // said there
  }
  if (!temperature.empty()) {
    arv::GErrorSlot err;
    const double t = arv_device_get_float_feature_value(dev, temperature.c_str(), err.out());
    if (!err && std::isfinite(t) && (!said_temperature_ || std::abs(t - *said_temperature_) >= 1.0)) {
      said_temperature_ = t;
      emit(CameraEvent::Kind::State, fmt::format("{}: device temperature {:.1f} C ({})", label(), t, temperature));
    }
  }
  if (!ptp.empty()) {
    arv::GErrorSlot err;
    const char* status = arv_device_get_string_feature_value(dev, ptp.c_str(), err.out());
    if (!err && status && said_ptp_status_ != status) {
      emit(CameraEvent::Kind::State,
           fmt::format("{}: PTP status {}{} ({})", label(), status,
                       said_ptp_status_.empty() ? "" : " (was " + said_ptp_status_ + ")", ptp));
      said_ptp_status_ = status;
    }
  }
}

void AravisCamera::request_stop() {
  running_.store(false);
  wake_.notify_all();
}

void AravisCamera::stop() {
  request_stop();
  if (trigger_thread_.joinable()) trigger_thread_.join();
  if (probe_thread_.joinable()) probe_thread_.join();
  if (control_thread_.joinable())
    control_thread_.join();  // its loop tears the connection down
  else
    teardown_connection(true);  // opened but never started
  {
    std::lock_guard feed(feed_mu_);
    stopped_ = true;  // the consumer closes the losses once it has taken every frame
  }
  probes_.close();
}

}  // namespace pvcap
