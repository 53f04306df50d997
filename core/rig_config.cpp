#include "core/rig_config.h"

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "core/result.h"
#include "core/yaml_map_reader.h"

namespace pvcap {

const char* to_string(TriggerMode mode) {
  switch (mode) {
    case TriggerMode::FreeRun: return "free-run";
    case TriggerMode::Software: return "software";
    case TriggerMode::Hardware: return "hardware";
  }
  return "?";
}

namespace {

CameraConfig parse_camera(const YAML::Node& node, const std::filesystem::path& file, std::size_t index) {
  CameraConfig c;
  c.name = fmt::format("cam{}", index);
  MapReader r(node, file, fmt::format("cameras[{}]", index));
  c.line = node.Mark().line + 1;
  r.get("name", c.name);
  r.get("serial", c.serial);
  r.get("address", c.address);
  if (c.serial.empty() && c.address.empty()) r.fail(node, "", "needs a 'serial' or an 'address'");
  r.get("pixel_format", c.pixel_format);
  static const std::set<std::string> formats = {"BayerRG8", "BayerBG8", "BayerGB8", "BayerGR8", "Mono8", "RGB8"};
  if (!formats.count(c.pixel_format))
    r.fail(node["pixel_format"], "pixel_format",
           fmt::format("'{}' is not supported (BayerRG8, BayerBG8, BayerGB8, BayerGR8, Mono8, RGB8)", c.pixel_format));
  r.get_in_range("width", c.width, 16, 8192);
  r.get_in_range("height", c.height, 16, 8192);
  r.get_in_range("offset_x", c.offset_x, 0, 8192);
  r.get_in_range("offset_y", c.offset_y, 0, 8192);
  if (c.width % 2 || c.height % 2) r.fail(node, "width", "width and height must be even (Bayer pattern)");
  r.get_in_range("frame_rate", c.frame_rate, 0.1, 1000.0);
  r.get_in_range("exposure_us", c.exposure_us, 1.0, 10'000'000.0);
  r.get_in_range("gain", c.gain, 0.0, 1000.0);
  std::string trigger = "free-run";
  r.get("trigger", trigger);
  if (trigger == "free-run") c.trigger = TriggerMode::FreeRun;
  else if (trigger == "software") c.trigger = TriggerMode::Software;
  else if (trigger == "hardware") c.trigger = TriggerMode::Hardware;
  else r.fail(node["trigger"], "trigger", fmt::format("'{}' is not one of free-run, software, hardware", trigger));
  r.get("trigger_source", c.trigger_source);
  r.get_in_range("packet_size", c.packet_size, 0, 65000);
  if (c.packet_size != 0 && c.packet_size < 576) r.fail(node["packet_size"], "packet_size", "must be 0 (auto) or >= 576");
  r.get_in_range("socket_buffer_bytes", c.socket_buffer_bytes, 0, 1 << 30);
  r.get("packet_resend", c.packet_resend);
  r.get_in_range("buffer_count", c.buffer_count, 0, 10000);
  r.get_in_range("link_mbps", c.link_mbps, 1.0, 1'000'000.0);
  r.get_in_range("latency_ns", c.latency_ns, std::int64_t{0}, std::int64_t{10'000'000'000});
  r.finish();
  return c;
}

SenselRigConfig parse_sensel(const YAML::Node& node, const std::filesystem::path& file) {
  SenselRigConfig c;
  MapReader r(node, file, "sensel");
  c.line = node.Mark().line + 1;
  r.get("tty", c.tty);
  if (r.has("usb")) {
    std::string serial;
    r.get("usb", serial);
    c.usb_serial = serial == "any" ? "" : serial;
  }
  if (r.has("tty") == r.has("usb"))
    r.fail(node, "tty/usb",
           "say where the Morph is with exactly one of tty: (/dev/ttyACM0, /dev/morph0, sim) or usb: (its USB "
           "serial string, or any)");
  if (c.usb_serial && c.usb_serial->empty() && r.node()["usb"].Scalar() != "any")
    r.fail(node["usb"], "usb", "empty: give the Morph's USB serial string (pvcap devices lists it) or 'any'");
  std::string detail = "medium";
  r.get("scan_detail", detail);
  if (detail == "high") c.scan_detail = 0;
  else if (detail == "medium") c.scan_detail = 1;
  else r.fail(node["scan_detail"], "scan_detail", fmt::format("'{}' is not one of high, medium", detail));
  r.get("dynamic_baseline", c.dynamic_baseline);
  r.get_in_range("frame_rate_cap", c.frame_rate_cap, 0, 2000);
  r.get_in_range("latency_ns", c.latency_ns, std::int64_t{0}, std::int64_t{1'000'000'000});
  r.finish();
  return c;
}

StoreConfig parse_store(const YAML::Node& node, const std::filesystem::path& file) {
  StoreConfig s;
  MapReader r(node, file, "store");
  r.get("video_mode", s.video_mode);
  if (s.video_mode != "raw" && s.video_mode != "color")
    r.fail(r.node()["video_mode"], "video_mode", fmt::format("'{}' is not one of raw, color", s.video_mode));
  r.get("raw_codec", s.raw_codec);
  if (s.raw_codec != "ffvhuff" && s.raw_codec != "ffv1" && s.raw_codec != "libx264")
    r.fail(r.node()["raw_codec"], "raw_codec",
           fmt::format("'{}' is not one of ffvhuff, ffv1, libx264 (lossless codecs of grey pictures)", s.raw_codec));
  r.get("video_codec", s.video_codec);
  r.get_in_range("crf", s.crf, 0, 51);
  r.get("preset", s.preset);
  r.get("video_pixel_format", s.video_pixel_format);
  r.get_in_range("video_fps", s.video_fps, 0.0, 1000.0);
  double gop_s = s.gop_seconds_x10 / 10.0;
  r.get_in_range("gop_seconds", gop_s, 0.1, 1.0);
  s.gop_seconds_x10 = int(std::lround(gop_s * 10));
  r.get_in_range("queue_frames", s.queue_frames, 2, 10000);
  r.get_in_range("segment_seconds", s.segment_seconds, 0.0, 86400.0);
  if (s.segment_seconds > 0 && s.segment_seconds < 1)  // a segment holds at least one GOP
    r.fail(r.node()["segment_seconds"], "segment_seconds", "must be 0 (one file per camera) or at least 1");
  r.get_in_range("min_free_mb", s.min_free_mb, 0, 1'000'000);
  r.get_in_range("reserve_mb", s.reserve_mb, 0, 100'000);
  r.finish();
  return s;
}

SimConfig parse_sim(const YAML::Node& node, const std::filesystem::path& file, std::size_t n_cameras) {
  SimConfig s;
  MapReader r(node, file, "sim");
  r.get("seed", s.seed);
  if (r.has("replay")) {
    std::string dir;
    r.get("replay", dir);
    if (dir.empty()) r.fail(node["replay"], "replay", "expected the folder of a recorded session");
    // Relative to the rig file, like every other path in it.
    s.replay = std::filesystem::path(dir).is_absolute() ? std::filesystem::path(dir) : file.parent_path() / dir;
    r.get_in_range("replay_rate", s.replay_rate, 0.1, 10.0);
  }
  const YAML::Node cams = r.child("cameras");
  if (cams) {
    if (!cams.IsSequence()) r.fail(cams, "cameras", "expected a list, one entry per rig camera");
    if (cams.size() != n_cameras)
      r.fail(cams, "cameras", fmt::format("has {} entries but the rig has {} cameras", cams.size(), n_cameras));
    for (std::size_t i = 0; i < cams.size(); ++i) {
      SimCameraClock c;
      MapReader cr(cams[i], file, fmt::format("sim.cameras[{}]", i));
      cr.get_in_range("clock_offset_ms", c.offset_ms, 0.0, 1e9);  // device time at power-on; >= 0
      cr.get_in_range("exposure_latency_ms", c.exposure_latency_ms, 0.0, 1000.0);
      cr.get_in_range("undeclared_latency_ms", c.undeclared_latency_ms, -1000.0, 1000.0);
      cr.get_in_range("drift_ppm", c.drift_ppm, -10000.0, 10000.0);
      cr.get_in_range("jitter_us", c.jitter_us, 0.0, 1e6);
      cr.get_in_range("packet_loss", c.packet_loss, 0.0, 1.0);
      if (cr.has("stop_after_s")) {
        double v = 0;
        cr.get_in_range("stop_after_s", v, 0.0, 1e7);
        c.stop_after_s = v;
      }
      if (cr.has("return_after_s")) {
        double v = 0;
        cr.get_in_range("return_after_s", v, 0.0, 1e7);
        if (!c.stop_after_s || v <= *c.stop_after_s)
          cr.fail(cams[i]["return_after_s"], "return_after_s", "needs a stop_after_s before it");
        c.return_after_s = v;
      }
      cr.get("trigger_line", c.trigger_line);
      cr.get_numbers("position_mm", c.position_mm);
      cr.get_numbers("look_at_mm", c.look_at_mm);
      if (cr.has("focal_px")) {
        double v = 0;
        cr.get_in_range("focal_px", v, 50.0, 100000.0);
        c.focal_px = v;
      }
      cr.get_numbers("distortion", c.distortion);
      if (c.position_mm && (*c.position_mm)[2] <= 0)
        cr.fail(cams[i]["position_mm"], "position_mm", "the camera must stand above the pad (z > 0 mm)");
      cr.finish();
      s.cameras.push_back(c);
    }
  } else {
    s.cameras.resize(n_cameras);
  }
  if (const YAML::Node sn = r.child("sensel")) {
    MapReader sr(sn, file, "sim.sensel");
    sr.get_in_range("press_x_mm", s.sensel.press_x_mm, 0.0, 230.0);
    sr.get_in_range("press_y_mm", s.sensel.press_y_mm, 0.0, 130.0);
    sr.get_in_range("peak_grams", s.sensel.peak_grams, 0.0, 4000.0);
    sr.get_in_range("period_s", s.sensel.period_s, 0.1, 1000.0);
    sr.get_in_range("clock_start_us", s.sensel.clock_start_us, 0.0, 4294967295.0);
    sr.get_in_range("drift_ppm", s.sensel.drift_ppm, -10000.0, 10000.0);
    sr.get_in_range("usb_jitter_mean_ms", s.sensel.usb_jitter_mean_ms, 0.0, 100.0);
    sr.get_in_range("usb_jitter_max_ms", s.sensel.usb_jitter_max_ms, 0.0, 1000.0);
    sr.get_in_range("drop_fraction", s.sensel.drop_fraction, 0.0, 0.5);
    if (sr.has("clock_reset_at_s")) {
      double v = 0;
      sr.get_in_range("clock_reset_at_s", v, 0.0, 1e7);
      s.sensel.clock_reset_at_s = v;
    }
    if (sr.has("unplug_at_s")) {
      double v = 0;
      sr.get_in_range("unplug_at_s", v, 0.0, 1e7);
      s.sensel.unplug_at_s = v;
    }
    if (sr.has("replug_after_s")) {
      double v = 0;
      sr.get_in_range("replug_after_s", v, 0.0, 1e7);
      if (!s.sensel.unplug_at_s) sr.fail(sn["replug_after_s"], "replug_after_s", "needs an unplug_at_s before it");
      s.sensel.replug_after_s = v;
    }
    if (sr.has("replug_serial")) {
      std::string v;
      sr.get("replug_serial", v);
      s.sensel.replug_serial = v;
    }
    if (sr.has("replug_renamed")) {
      sr.get("replug_renamed", s.sensel.replug_renamed);
      if (!s.sensel.replug_after_s)
        sr.fail(sn["replug_renamed"], "replug_renamed", "needs a replug_after_s before it");
    }
    sr.finish();
  }
  r.finish();
  return s;
}

}  // namespace

double sample_rate_hz(const RigConfig& rig) {
  if (rig.store.video_fps > 0) return rig.store.video_fps;
  double fastest = 0;
  for (const auto& c : rig.cameras) fastest = std::max(fastest, c.frame_rate);
  return fastest > 0 ? fastest : 60.0;
}

RigConfig parse_rig_config(const std::string& text, const std::filesystem::path& source) {
  RigConfig rig;
  rig.source = source;
  rig.text = text;
  const YAML::Node root = load_yaml(text, source);
  if (!root || root.IsNull()) throw UserError(fmt::format("{}:1: the rig file is empty", source.string()));
  try {
    MapReader r(root, source, "");
    r.require("name", rig.name);
    const YAML::Node cams = r.child("cameras");
    if (!cams || !cams.IsSequence() || cams.size() == 0)
      r.fail(cams ? cams : root, "cameras", "expected a non-empty list of cameras");
    std::set<std::string> names, ids;
    for (std::size_t i = 0; i < cams.size(); ++i) {
      CameraConfig c = parse_camera(cams[i], source, i);
      if (!names.insert(c.name).second)
        r.fail(cams[i], fmt::format("cameras[{}].name", i), fmt::format("'{}' is used twice", c.name));
      if (!ids.insert(c.id()).second)
        r.fail(cams[i], fmt::format("cameras[{}]", i), fmt::format("camera '{}' is listed twice", c.id()));
      rig.cameras.push_back(std::move(c));
    }
    if (const YAML::Node sensel = r.child("sensel")) rig.sensel = parse_sensel(sensel, source);
    if (const YAML::Node store = r.child("store")) rig.store = parse_store(store, source);
    if (const YAML::Node sim = r.child("sim")) rig.sim = parse_sim(sim, source, rig.cameras.size());
    if (rig.sensel && rig.sensel->tty == "sim" && !rig.sim)
      r.fail(root["sensel"], "sensel.tty", "'sim' needs a sim: section (a simulated rig)");
    r.finish();
  } catch (const YAML::Exception& e) {
    throw UserError(fmt::format("{}:{}: {}", source.string(), e.mark.line + 1, e.msg));
  }
  return rig;
}

RigConfig load_rig_config(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw UserError(fmt::format("{}: cannot open the rig file", path.string()));
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_rig_config(ss.str(), path);
}

}  // namespace pvcap
