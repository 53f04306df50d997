#include "core/rig_config.h"

#include <cctype>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "core/result.h"
#include "core/yaml_map_reader.h"

namespace pvcap {

const char* to_string(TimestampMarks marks) {
  return marks == TimestampMarks::ExposureStart    ? "exposure_start"
         : marks == TimestampMarks::ExposureMiddle ? "exposure_middle"
                                                   : "exposure_end";
}

std::int64_t stamp_to_mid_exposure_ns(TimestampMarks marks, double exposure_us) {
  const auto half = std::int64_t(std::llround(exposure_us * 500.0));
  return marks == TimestampMarks::ExposureStart ? half : marks == TimestampMarks::ExposureEnd ? -half : 0;
}

const char* to_string(TriggerMode mode) {
  switch (mode) {
    case TriggerMode::FreeRun:
      return "free-run";
    case TriggerMode::Software:
      return "software";
    case TriggerMode::Hardware:
      return "hardware";
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
  if (c.serial.empty() && c.address.empty()) r.fail_missing(node, "", "needs a 'serial' or an 'address'");
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
  if (trigger == "free-run")
    c.trigger = TriggerMode::FreeRun;
  else if (trigger == "software")
    c.trigger = TriggerMode::Software;
  else if (trigger == "hardware")
    c.trigger = TriggerMode::Hardware;
  else
    r.fail(node["trigger"], "trigger", fmt::format("'{}' is not one of free-run, software, hardware", trigger));
  r.get("trigger_source", c.trigger_source);
  r.get_in_range("packet_size", c.packet_size, 0, 65000);
  if (c.packet_size != 0 && c.packet_size < 576)
    r.fail(node["packet_size"], "packet_size", "must be 0 (auto) or >= 576");
  r.get_in_range("socket_buffer_bytes", c.socket_buffer_bytes, 0, 1 << 30);
  r.get("packet_resend", c.packet_resend);
  r.get("chunk_data", c.chunk_data);
  r.get_in_range("buffer_count", c.buffer_count, 0, 10000);
  r.get_in_range("link_mbps", c.link_mbps, 1.0, 1'000'000.0);
  r.get("link", c.link);
  r.get_in_range("latency_ns", c.latency_ns, std::int64_t{0}, std::int64_t{10'000'000'000});
  std::string marks = "exposure_start";
  r.get("timestamp_marks", marks);
  if (marks == "exposure_start")
    c.timestamp_marks = TimestampMarks::ExposureStart;
  else if (marks == "exposure_middle")
    c.timestamp_marks = TimestampMarks::ExposureMiddle;
  else if (marks == "exposure_end")
    c.timestamp_marks = TimestampMarks::ExposureEnd;
  else
    r.fail(node["timestamp_marks"], "timestamp_marks",
           fmt::format("'{}' is not one of exposure_start, exposure_middle, exposure_end", marks));
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
  (void)r.child("usb");  // read above when present; known either way (a typo of it is said as one)
  if (r.has("tty") == r.has("usb")) {
    const char* where =
        "say where the Morph is with exactly one of tty: (/dev/ttyACM0, /dev/morph0, sim) or usb: (its USB "
        "serial string, or any)";
    if (r.has("tty"))
      r.fail(node, "tty/usb", where);
    else
      r.fail_missing(node, "tty/usb", where);
  }
  if (c.usb_serial && c.usb_serial->empty() && r.node()["usb"].Scalar() != "any")
    r.fail(node["usb"], "usb", "empty: give the Morph's USB serial string (pvcap devices lists it) or 'any'");
  std::string detail = "medium";
  r.get("scan_detail", detail);
  if (detail == "high")
    c.scan_detail = 0;
  else if (detail == "medium")
    c.scan_detail = 1;
  else
    r.fail(node["scan_detail"], "scan_detail", fmt::format("'{}' is not one of high, medium", detail));
  r.get("dynamic_baseline", c.dynamic_baseline);
  r.get_in_range("frame_rate_cap", c.frame_rate_cap, 0, 2000);
  r.get_in_range("latency_ns", c.latency_ns, std::int64_t{0}, std::int64_t{1'000'000'000});
  r.finish();
  return c;
}

PtpRigConfig parse_ptp(const YAML::Node& node, const std::filesystem::path& file) {
  PtpRigConfig c;
  MapReader r(node, file, "ptp");
  c.line = node.Mark().line + 1;
  r.get("host", c.host);
  r.get("cameras", c.cameras);
  r.get_in_range("lock_wait_s", c.lock_wait_s, 0.0, 600.0);
  r.get("ptp4l_socket", c.ptp4l_socket);
  if (c.ptp4l_socket.empty()) r.fail(node["ptp4l_socket"], "ptp4l_socket", "empty: give ptp4l's uds_address");
  r.get_in_range("max_offset_us", c.max_offset_us, 0.001, 10'000.0);
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
  if (s.raw_codec != "ffvhuff" && s.raw_codec != "ffv1" && s.raw_codec != "libx264" && s.raw_codec != "magicyuv")
    r.fail(r.node()["raw_codec"], "raw_codec",
           fmt::format("'{}' is not one of ffvhuff, magicyuv, ffv1, libx264 (lossless codecs of grey pictures)",
                       s.raw_codec));
  std::string tiles = "auto";
  r.get("raw_tiles", tiles);
  if (tiles != "auto") {
    int cols = 0, rows = 0;
    char extra = 0;
    if (std::sscanf(tiles.c_str(), "%dx%d%c", &cols, &rows, &extra) != 2 || cols < 1 || rows < 1 || cols > 64 ||
        rows > 64)
      r.fail(r.node()["raw_tiles"], "raw_tiles",
             fmt::format("'{}' is not auto or COLSxROWS (1x1 to 64x64; 1x1: one picture per frame)", tiles));
    s.raw_tile_cols = cols;
    s.raw_tile_rows = rows;
  }
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
  r.get_in_range("sync_interval_s", s.sync_interval_s, 0.0, 60.0);
  r.get("group", s.group);
  r.get("view_videos", s.view_videos);
  r.finish();
  return s;
}

// The rig's lights (LightConfig), each also given to the camera that drives it.
void parse_lights(const YAML::Node& lights, const std::filesystem::path& source, const MapReader& r, RigConfig& rig) {
  if (!lights.IsSequence()) r.fail(lights, "lights", "expected a list of lights (name, camera, line, mode)");
  for (std::size_t i = 0; i < lights.size(); ++i) {
    const std::string where = fmt::format("lights[{}]", i);
    MapReader lr(lights[i], source, where);
    LightConfig l;
    l.line_no = lights[i].Mark().line + 1;
    lr.require("name", l.name);
    lr.require("camera", l.camera);
    lr.require("line", l.line);
    std::string mode = "steady";
    lr.get("mode", mode);
    if (mode != "steady" && mode != "strobe")
      lr.fail(lights[i]["mode"], "mode", fmt::format("'{}' is not one of steady, strobe", mode));
    l.strobe = mode == "strobe";
    lr.finish();
    if (l.name.size() != 1 || l.name[0] < 'A' || l.name[0] > 'Z')
      r.fail(lights[i]["name"], where + ".name",
             fmt::format("'{}': a light's name is one capital letter of the lighting codes (L, C, R)", l.name));
    for (const LightConfig& o : rig.lights) {
      if (o.name == l.name) r.fail(lights[i]["name"], where + ".name", fmt::format("'{}' is used twice", l.name));
      if (o.camera == l.camera && o.line == l.line)
        r.fail(lights[i]["line"], where + ".line",
               fmt::format("{}'s {} already drives light {}", l.camera, l.line, o.name));
    }
    auto cam =
        std::find_if(rig.cameras.begin(), rig.cameras.end(), [&](const CameraConfig& c) { return c.name == l.camera; });
    if (cam == rig.cameras.end())
      r.fail(lights[i]["camera"], where + ".camera", fmt::format("'{}' is not one of the rig's cameras", l.camera));
    cam->lights.push_back(l);
    rig.lights.push_back(std::move(l));
  }
}

}  // namespace

int line_number(const std::string& line) {
  std::size_t at = line.size();
  while (at > 0 && std::isdigit(static_cast<unsigned char>(line[at - 1]))) --at;
  if (at == line.size() || line.size() - at > 6) return -1;
  return std::stoi(line.substr(at));
}

double grouping_rate_hz(const RigConfig& rig) {
  double fastest = 0;
  for (const auto& c : rig.cameras) fastest = std::max(fastest, c.frame_rate);
  return fastest > 0 ? fastest : 60.0;
}

double sample_rate_hz(const RigConfig& rig) {
  return rig.store.video_fps > 0 ? rig.store.video_fps : grouping_rate_hz(rig);
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
    // Cameras on one link: counted, and one capacity for it.
    for (std::size_t i = 0; i < rig.cameras.size(); ++i) {
      CameraConfig& c = rig.cameras[i];
      if (c.link.empty()) continue;
      c.link_cameras = 0;
      for (std::size_t j = 0; j < rig.cameras.size(); ++j) {
        const CameraConfig& o = rig.cameras[j];
        if (o.link != c.link) continue;
        ++c.link_cameras;
        if (o.link_mbps != c.link_mbps)
          r.fail(cams[i], fmt::format("cameras[{}].link_mbps", i),
                 fmt::format("{} and {} share link '{}' but give it {:g} and {:g} Mbit/s: one link, one capacity",
                             c.name, o.name, c.link, c.link_mbps, o.link_mbps));
      }
    }
    if (const YAML::Node lights = r.child("lights")) parse_lights(lights, source, r, rig);
    for (CameraConfig& c : rig.cameras) c.rig_switches_lights = !rig.lights.empty();
    if (const YAML::Node sensel = r.child("sensel")) rig.sensel = parse_sensel(sensel, source);
    if (const YAML::Node store = r.child("store")) rig.store = parse_store(store, source);
    if (const YAML::Node ptp = r.child("ptp")) {  // `ptp:` alone: every default
      rig.ptp = parse_ptp(ptp.IsNull() ? YAML::Node(YAML::NodeType::Map) : ptp, source);
      if (ptp.IsNull()) rig.ptp->line = ptp.Mark().line + 1;
      for (CameraConfig& c : rig.cameras) c.ptp = rig.ptp->cameras;
    }
    // The simulator's section: read by sim/sim_config.h, so only its presence is noted here.
    if (const YAML::Node sim = r.child("sim")) {
      if (!sim.IsMap()) r.fail(sim, "sim", "expected a mapping (the simulated devices' settings)");
      rig.simulated = true;
    }
    if (rig.sensel && rig.sensel->tty == "sim" && !rig.simulated)
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
