#include "capture/aravis_camera.h"

#include "capture/aravis_features.h"
#include "capture/aravis_handles.h"
#include "capture/aravis_stream.h"
#include "capture/camera_watchdog.h"
#include "capture/genicam_features.h"
#include "capture/gvcp_ping.h"
#include "codec/pixel_format.h"
#include "core/thread_name.h"

#include <algorithm>
#include <cmath>
#include <fstream>

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

// The camera has the role and, now, the entry.
bool check_entry(const AravisFeatures& f, CameraRole role, const std::string& entry) {
  if (!f.has(role)) return false;
  const auto entries = f.entries(f.name(role));
  return std::find(entries.begin(), entries.end(), entry) != entries.end();
}
}  // namespace

long read_rmem_max() {
  std::ifstream in("/proc/sys/net/core/rmem_max");
  long v = 0;
  in >> v;
  return in ? v : 0;
}

std::size_t buffer_count_for(const CameraConfig& config) {
  if (config.buffer_count > 0) return std::size_t(config.buffer_count);
  return std::max<std::size_t>(8, std::size_t(std::ceil(config.frame_rate * 0.5)));
}

Status preflight(const std::string& label, const LinkBudget& b) {
  const double mbps = double(b.payload_bytes) * 8.0 * b.frame_rate * kProtocolOverhead / 1e6;
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

struct AravisCamera::Link {
  arv::GPtr<ArvCamera> camera;
  std::shared_ptr<AravisStream> stream;
  gulong control_lost_id = 0;
  // GLib's "control-lost" signal, on Aravis' heartbeat thread: wakes the control loop.
  static void on_control_lost(ArvGvDevice*, void* self) {
    auto* cam = static_cast<AravisCamera*>(self);
    cam->control_lost_.store(true);
    cam->wake_.notify_all();
  }
};

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

Status AravisCamera::apply_features() {
  ArvCamera* cam = link_->camera.get();
  AravisFeatures f(arv_camera_get_device(cam));
  arv::GErrorSlot err;
  arv_camera_stop_acquisition(cam, err.out());  // a camera left streaming by a crashed run

  // What this camera cannot do for the rig file, named before anything is set or recorded: the
  // offline check (`pvcap camera check`) on what the camera itself answers.
  const NodeMapCheck check = check_node_map(f, config_);
  if (!check.usable())
    return Error{
        fmt::format("{}: {} {} cannot record as the rig file asks: {} (`pvcap camera check` on its node "
                    "map, from `pvcap devices --dump-node-map`, lists what it has)",
                    label(), check.vendor, check.model, fmt::join(check.missing, "; "))};
  if (!features_said_) {
    for (const auto& w : check.warnings)
      if (check.clock == "latch" || w.find("timestamp latch") == std::string::npos) spdlog::warn("{}: {}", label(), w);
  }
  if (Status s = set_features(f); !s.ok()) return s;
  return read_back(f, check);
}

#define PVCAP_TRY(expr)      \
  do {                       \
    Status s_ = (expr);      \
    if (!s_.ok()) return s_; \
  } while (0)

Status AravisCamera::setting(Status s, const std::string& what) const {
  if (s.ok()) return s;
  return Error{fmt::format("{}: setting {} failed: {}", label(), what, s.error().message)};
}

Status AravisCamera::set_features(AravisFeatures& f) {
  ArvCamera* cam = link_->camera.get();
  arv::GErrorSlot err;
  auto set = [this](Status s, const std::string& what) { return setting(std::move(s), what); };
  if (check_entry(f, CameraRole::AcquisitionMode, "Continuous"))
    PVCAP_TRY(set(f.set_entry(CameraRole::AcquisitionMode, "Continuous"), "the acquisition mode"));
  PVCAP_TRY(set(f.set_entry(CameraRole::PixelFormat, config_.pixel_format), "the pixel format"));
  // The offsets go to 0 first: a region is checked against the sensor with the offsets it has.
  const std::string region =
      fmt::format("the region to {}x{}+{}+{}", config_.width, config_.height, config_.offset_x, config_.offset_y);
  for (CameraRole r : {CameraRole::OffsetX, CameraRole::OffsetY})
    if (f.has(r)) PVCAP_TRY(set(f.set_number(r, 0), region));
  PVCAP_TRY(set(f.set_number(CameraRole::Width, config_.width), region));
  PVCAP_TRY(set(f.set_number(CameraRole::Height, config_.height), region));
  for (auto [r, v] :
       {std::pair{CameraRole::OffsetX, config_.offset_x}, std::pair{CameraRole::OffsetY, config_.offset_y}})
    if (v != 0 || f.has(r)) PVCAP_TRY(set(f.set_number(r, v), region));

  PVCAP_TRY(set_trigger_and_rate(f));
  // Automatic exposure or gain would change the images within a take and across a dataset.
  for (CameraRole r : {CameraRole::ExposureAuto, CameraRole::GainAuto})
    if (check_entry(f, r, "Off")) PVCAP_TRY(set(f.set_entry(r, "Off"), role_key(r)));
  PVCAP_TRY(set(f.set_number(CameraRole::ExposureTime, config_.exposure_us),
                fmt::format("the exposure to {:g} us", config_.exposure_us)));
  if (f.has(CameraRole::Gain) || config_.gain != 0)
    PVCAP_TRY(set(f.set_number(CameraRole::Gain, config_.gain), fmt::format("the gain to {:g}", config_.gain)));
  // The stream channel's packet size: GigE Vision's own register (Aravis reaches it under its own
  // name whatever the camera's map declares), negotiated by Aravis' test packets.
  if (config_.packet_size > 0) {
    arv_camera_gv_set_packet_size(cam, config_.packet_size, err.out());
    if (err)
      return Error{
          fmt::format("{}: setting the packet size to {} failed: {}", label(), config_.packet_size, err.message())};
  } else {
    arv_camera_gv_auto_packet_size(cam, err.out());
    if (err) return Error{fmt::format("{}: negotiating the packet size failed: {}", label(), err.message())};
  }
  return {};
}

Status AravisCamera::set_trigger_and_rate(AravisFeatures& f) {
  auto set = [this](Status s, const std::string& what) { return setting(std::move(s), what); };
  // Every trigger off first (a camera another program left waiting for an acquisition-start
  // trigger sends nothing), then the frame-start trigger as the rig asks.
  const auto selectors = f.all_entries(CameraRole::TriggerSelector);
  if (f.has(CameraRole::TriggerMode)) {
    for (const auto& selector : selectors)
      if (f.set_entry(CameraRole::TriggerSelector, selector).ok()) (void)f.set_entry(CameraRole::TriggerMode, "Off");
    if (std::find(selectors.begin(), selectors.end(), "FrameStart") != selectors.end())
      PVCAP_TRY(set(f.set_entry(CameraRole::TriggerSelector, "FrameStart"), "the trigger selector"));
    if (selectors.empty()) PVCAP_TRY(set(f.set_entry(CameraRole::TriggerMode, "Off"), "the trigger mode"));
  }
  if (config_.trigger == TriggerMode::FreeRun) {
    // FLIR takes a rate only with its enable on (older Point Grey: ...Enabled).
    if (f.has(CameraRole::FrameRateEnable))
      PVCAP_TRY(set(f.set_flag(CameraRole::FrameRateEnable, true), "the frame rate's enable"));
    if (f.has(CameraRole::FrameRate))
      PVCAP_TRY(set(f.set_number(CameraRole::FrameRate, config_.frame_rate),
                    fmt::format("the frame rate to {:g} fps", config_.frame_rate)));
  } else {
    // Triggered, a rate still enabled would cap the triggers it takes (Basler).
    if (f.has(CameraRole::FrameRateEnable))
      PVCAP_TRY(set(f.set_flag(CameraRole::FrameRateEnable, false), "the frame rate's enable"));
    const std::string source = config_.trigger == TriggerMode::Software ? "Software" : config_.trigger_source;
    PVCAP_TRY(set(f.set_entry(CameraRole::TriggerMode, "On"), "the trigger mode"));
    PVCAP_TRY(set(f.set_entry(CameraRole::TriggerSource, source), fmt::format("the trigger source to {}", source)));
    if (check_entry(f, CameraRole::TriggerActivation, "RisingEdge"))
      PVCAP_TRY(set(f.set_entry(CameraRole::TriggerActivation, "RisingEdge"), "the trigger activation"));
  }
  return {};
}
#undef PVCAP_TRY

// What the camera actually does after configuration: it may round or clamp.
Status AravisCamera::read_back(const AravisFeatures& f, const NodeMapCheck& check) {
  ArvCamera* cam = link_->camera.get();
  arv::GErrorSlot err;
  CameraSettings s;
  auto str = [&](const char* v) { return std::string(v ? v : ""); };
  s.vendor = str(arv_camera_get_vendor_name(cam, nullptr));
  s.model = str(arv_camera_get_model_name(cam, nullptr));
  s.serial = str(arv_camera_get_device_serial_number(cam, nullptr));
  s.device_id = str(arv_camera_get_device_id(cam, nullptr));
  s.firmware = f.text(CameraRole::FirmwareVersion).value_or("");
  ArvDevice* dev = arv_camera_get_device(cam);
  if (ARV_IS_GV_DEVICE(dev)) {
    GSocketAddress* sock = arv_gv_device_get_device_address(ARV_GV_DEVICE(dev));
    if (sock && G_IS_INET_SOCKET_ADDRESS(sock)) {
      GInetAddress* addr = g_inet_socket_address_get_address(G_INET_SOCKET_ADDRESS(sock));
      gchar* text = g_inet_address_to_string(addr);
      s.address = text;
      g_free(text);
    }
    s.timestamp_tick_hz = arv_gv_device_get_timestamp_tick_frequency(ARV_GV_DEVICE(dev), nullptr);
  }
  s.pixel_format = f.entry(CameraRole::PixelFormat).value_or("");
  const auto read_int = [&](CameraRole r) { return int(std::lround(f.number(r).value_or(0))); };
  s.x = read_int(CameraRole::OffsetX);
  s.y = read_int(CameraRole::OffsetY);
  s.width = read_int(CameraRole::Width);
  s.height = read_int(CameraRole::Height);
  s.frame_rate = f.number(CameraRole::FrameRate).value_or(0);
  s.exposure_us = f.number(CameraRole::ExposureTime).value_or(0);
  s.gain = f.number(CameraRole::Gain).value_or(0);
  s.trigger = to_string(config_.trigger);
  for (const auto& [role, name] : f.chosen()) s.features[role_key(role)] = name;
  s.node_map_version = check.version;
  s.packet_size = arv_camera_gv_get_packet_size(cam, nullptr);
  s.payload = arv_camera_get_payload(cam, err.out());
  if (err || s.payload == 0) return Error{fmt::format("{}: cannot read PayloadSize: {}", label(), err.message())};
  s.buffer_count = buffer_count_for(config_);
  if (config_.trigger == TriggerMode::FreeRun) {
    if (!f.has(CameraRole::FrameRate)) {
      s.frame_rate = config_.frame_rate;  // it cannot say (warned above): the budget takes the rig's
    } else if (std::abs(s.frame_rate - config_.frame_rate) > 0.01 * config_.frame_rate) {
      return Error{
          fmt::format("{}: asked for {:g} fps, it runs at {:.2f} ({} reads back so): lower frame_rate in the "
                      "rig file, or shorten exposure_us ({:g} us) or the region",
                      label(), config_.frame_rate, s.frame_rate, f.name(CameraRole::FrameRate), s.exposure_us)};
    }
  }
  if (!features_said_ && std::abs(s.exposure_us - config_.exposure_us) > 0.05 * config_.exposure_us)
    spdlog::warn("{}: asked for an exposure of {:g} us, it reads back {:g} ({})", label(), config_.exposure_us,
                 s.exposure_us, f.name(CameraRole::ExposureTime));
  // The camera's whole state, once: what a later question about this session's images may need.
  s.feature_bag = features_said_ ? settings_.feature_bag : f.feature_bag();
  features_said_ = true;
  settings_ = s;
  return {};
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
    return s;
  }
  const LinkBudget budget{settings_.payload, settings_.frame_rate, config_.link_mbps, config_.socket_buffer_bytes,
                          read_rmem_max()};
  if (Status s = preflight(label(), budget); !s.ok()) {
    link_->camera.reset();
    return s;
  }
  const ExpectedImage expected{settings_.width, settings_.height, pixel_format_code(settings_.pixel_format)};
  auto stream = AravisStream::create(link_->camera.get(), index_, connection, settings_.payload, settings_.buffer_count,
                                     config_.packet_resend, config_.socket_buffer_bytes, losses_, expected);
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
  Status s = connect_and_configure(connection_);
  if (s.ok()) {
    const CameraSettings st = settings();
    spdlog::info("{}: {} {} serial {} at {}, {} {}x{}+{}+{} @ {:.2f} fps, packet {} B, {} buffers of {} B", label(),
                 st.vendor, st.model, st.serial, st.address, st.pixel_format, st.width, st.height, st.x, st.y,
                 st.frame_rate, st.packet_size, st.buffer_count, st.payload);
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
  while (running_.load()) {
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
