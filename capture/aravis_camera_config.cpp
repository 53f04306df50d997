// AravisCamera's configuration: the rig file's camera section checked against what the camera
// answers, set feature by feature under the camera's own names (capture/aravis_features.h), and read
// back. Its connection, streaming and supervision are in aravis_camera.cpp.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include "capture/aravis_camera.h"
#include "capture/aravis_camera_link.h"
#include "capture/aravis_features.h"
#include "capture/genicam_node_map.h"

namespace pvcap {

namespace {
// The camera has the role and, now, the entry.
bool check_entry(const AravisFeatures& f, CameraRole role, const std::string& entry) {
  if (!f.has(role)) return false;
  const auto entries = f.entries(f.name(role));
  return std::find(entries.begin(), entries.end(), entry) != entries.end();
}
}  // namespace

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
  // A camera that comes back (power-cycled) has its output lines low: its lights as last switched.
  if (const std::uint32_t on = lights_on_.load(); on != kLightsNeverSwitched)
    if (auto lit = apply_lights(f, on); !lit || lit.value() != on)
      spdlog::warn("{}: its lights could not be switched back on as they were ({})", label(),
                   lit ? "they read back otherwise" : lit.error().message);
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
  if (config_.ptp) PVCAP_TRY(enable_ptp(f));
  // Automatic exposure or gain would change the images within a take and across a dataset.
  for (CameraRole r : {CameraRole::ExposureAuto, CameraRole::GainAuto}) {
    if (check_entry(f, r, "Off")) PVCAP_TRY(set(f.set_entry(r, "Off"), role_key(r)));
    // Switched lights are proven by the images' brightness, which an automatic exposure or gain undoes.
    if (config_.rig_switches_lights && f.has(r) && f.entry(r).value_or("Off") != "Off")
      return Error{fmt::format("{}: its {} stays {} and cannot be turned Off: with lights switched (lights:), an "
                               "automatic exposure or gain would hide every switch from the images",
                               label(), f.name(r), f.entry(r).value_or("?"))};
  }
  PVCAP_TRY(set(f.set_number(CameraRole::ExposureTime, config_.exposure_us),
                fmt::format("the exposure to {:g} us", config_.exposure_us)));
  if (f.has(CameraRole::Gain) || config_.gain != 0)
    PVCAP_TRY(set(f.set_number(CameraRole::Gain, config_.gain), fmt::format("the gain to {:g}", config_.gain)));
  set_chunks(f);  // before the payload is read back: the chunks add to it
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
  return set_link_pacing(f);
}

Status AravisCamera::unreachable_rate(const AravisFeatures& f, const std::string& said, double most) const {
  return Error{
      fmt::format("{}: cannot reach {:g} fps at {}x{} {} (exposure {:g} us): {} is {:.2f} there; lower "
                  "frame_rate, crop width/height, or shorten exposure_us",
                  label(), config_.frame_rate, config_.width, config_.height, config_.pixel_format,
                  f.number(CameraRole::ExposureTime).value_or(0), said, most)};
}

Status AravisCamera::set_link_pacing(AravisFeatures& f) {
  link_pacing_.clear();
  if (config_.link_cameras <= 1) return {};
  ArvCamera* cam = link_->camera.get();
  const std::size_t packet = arv_camera_gv_get_packet_size(cam, nullptr);
  const LinkPacing p = link_pacing(packet, config_.link_mbps, config_.link_cameras);
  const std::string shared = fmt::format("link '{}' ({:g} Mbit/s) shared by {} cameras", config_.link,
                                         config_.link_mbps, config_.link_cameras);
  if (!f.has(CameraRole::BandwidthLimit)) {
    if (!features_said_)
      spdlog::warn(
          "{}: on {}, but it has no packet delay or throughput limit (GevSCPD, StreamBytesPerSecond, "
          "DeviceLinkThroughputLimit): its frames go out at line rate, and the cameras' bursts may "
          "overflow the link's port",
          label(), shared);
    return {};
  }
  const std::string name = f.name(CameraRole::BandwidthLimit);
  if (name == "GevSCPD") {
    // GigE Vision's inter-packet delay counts timestamp ticks (nanoseconds on SFNC 2 cameras).
    ArvDevice* dev = arv_camera_get_device(cam);
    const std::uint64_t hz =
        ARV_IS_GV_DEVICE(dev) ? arv_gv_device_get_timestamp_tick_frequency(ARV_GV_DEVICE(dev), nullptr) : 0;
    const double ticks = std::ceil(p.packet_delay_s * double(hz > 0 ? hz : 1'000'000'000));
    if (Status s = f.set_number(CameraRole::BandwidthLimit, ticks); !s.ok())
      return Error{fmt::format(
          "{}: on {}, its {}-byte packets need {:.2f} us between them ({:g} ticks of its "
          "GevSCPD) to keep to a share of {:.0f} Mbit/s, which it cannot: {}. Use fewer cameras "
          "on the link, a larger packet_size, or a faster link",
          label(), shared, packet, p.packet_delay_s * 1e6, ticks, p.share_bytes_per_s * 8 / 1e6, s.error().message)};
    link_pacing_ =
        fmt::format("GevSCPD {:g} ticks ({:.2f} us between its {}-byte packets) on {}",
                    f.number(CameraRole::BandwidthLimit).value_or(-1), p.packet_delay_s * 1e6, packet, shared);
  } else {
    // Allied Vision's StreamBytesPerSecond and SFNC's DeviceLinkThroughputLimit: bytes per second.
    if (f.has(CameraRole::BandwidthLimitMode)) (void)f.set_flag(CameraRole::BandwidthLimitMode, true);
    if (Status s = f.set_number(CameraRole::BandwidthLimit, std::floor(p.share_bytes_per_s)); !s.ok())
      return Error{fmt::format("{}: on {}, its share is {:.0f} bytes/s, which its {} cannot be set to: {}", label(),
                               shared, p.share_bytes_per_s, name, s.error().message)};
    link_pacing_ =
        fmt::format("{} {:g} bytes/s on {}", name, f.number(CameraRole::BandwidthLimit).value_or(-1), shared);
  }
  if (!features_said_) spdlog::info("{}: paced: {}", label(), link_pacing_);
  return {};
}

void AravisCamera::set_chunks(AravisFeatures& f) {
  chunk_features_.clear();
  if (!f.has(CameraRole::ChunkModeActive)) return;
  const bool selectable = f.has(CameraRole::ChunkSelector) && f.has(CameraRole::ChunkEnable);
  const auto entries = selectable ? f.all_entries(CameraRole::ChunkSelector) : std::vector<std::string>{};
  std::map<CameraRole, std::string> enabled;
  // Chunk mode off first: some cameras take a selector's enable only then, and a camera asked for
  // no chunks is left without them.
  (void)f.set_flag(CameraRole::ChunkModeActive, false);
  if (!config_.chunk_data || !selectable) return;
  for (CameraRole role : {CameraRole::ChunkFrameCounter, CameraRole::ChunkTimestamp, CameraRole::ChunkExposureTime,
                          CameraRole::ChunkGain, CameraRole::ChunkLineStatus}) {
    if (!f.has(role)) continue;
    // The selector's entry is the value's name without "Chunk" (ChunkExposureTime: ExposureTime).
    const std::string entry = f.name(role).substr(5);
    if (std::find(entries.begin(), entries.end(), entry) == entries.end()) continue;
    if (f.set_entry(CameraRole::ChunkSelector, entry).ok() && f.set_flag(CameraRole::ChunkEnable, true).ok())
      enabled[role] = f.name(role);
  }
  if (enabled.empty()) return;
  if (Status s = f.set_flag(CameraRole::ChunkModeActive, true); !s.ok()) {
    if (!features_said_)
      spdlog::warn("{}: chunk mode could not be turned on ({}): frames are stored without their own exposure and gain",
                   label(), s.error().message);
    return;
  }
  chunk_features_ = std::move(enabled);
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
    // The fastest it can go at the rig's region and format (set above), its rate's maximum now: named
    // before a rate is refused (the rate it says it reaches is checked once the exposure is set too).
    if (f.has(CameraRole::FrameRate)) {
      if (const auto r = f.range(f.name(CameraRole::FrameRate)); r && config_.frame_rate > r->second * 1.001)
        return unreachable_rate(f, fmt::format("{}'s maximum", f.name(CameraRole::FrameRate)), r->second);
      PVCAP_TRY(set(f.set_number(CameraRole::FrameRate, config_.frame_rate),
                    fmt::format("the frame rate to {:g} fps", config_.frame_rate)));
    }
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
  // Where Aravis' call finds none (another transport, a register not implemented), the map's feature.
  if (s.timestamp_tick_hz == 0 && f.has(CameraRole::TimestampTickFrequency))
    s.timestamp_tick_hz = std::uint64_t(std::llround(f.number(CameraRole::TimestampTickFrequency).value_or(0)));
  s.pixel_format = f.entry(CameraRole::PixelFormat).value_or("");
  const auto read_int = [&](CameraRole r) { return int(std::lround(f.number(r).value_or(0))); };
  s.x = read_int(CameraRole::OffsetX);
  s.y = read_int(CameraRole::OffsetY);
  s.width = read_int(CameraRole::Width);
  s.height = read_int(CameraRole::Height);
  s.frame_rate = f.number(CameraRole::FrameRate).value_or(0);
  s.exposure_us = f.number(CameraRole::ExposureTime).value_or(0);
  s.gain = f.number(CameraRole::Gain).value_or(0);
  s.gain_unit = role_unit(CameraRole::Gain, f.name(CameraRole::Gain));
  if (const auto chunk = chunk_features_.find(CameraRole::ChunkGain); chunk != chunk_features_.end())
    s.chunk_gain_unit = role_unit(CameraRole::ChunkGain, chunk->second);
  s.trigger = to_string(config_.trigger);
  for (const auto& [role, name] : f.chosen()) s.features[role_key(role)] = name;
  for (const auto& [role, name] : chunk_features_) s.chunks[role_key(role)] = name;
  s.node_map_version = check.version;
  s.link_pacing = link_pacing_;
  s.packet_size = arv_camera_gv_get_packet_size(cam, nullptr);
  s.payload = arv_camera_get_payload(cam, err.out());
  if (err || s.payload == 0) return Error{fmt::format("{}: cannot read PayloadSize: {}", label(), err.message())};
  s.buffer_count = buffer_count_for(config_);
  if (config_.trigger == TriggerMode::FreeRun) {
    // With region, format and exposure all set, the rate the camera says it reaches.
    if (const auto r = f.number(CameraRole::ResultingFrameRate); r && *r > 0 && config_.frame_rate > *r * 1.01)
      return unreachable_rate(f, f.name(CameraRole::ResultingFrameRate), *r);
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

}  // namespace pvcap
