#include "sim/sim_config.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "core/result.h"
#include "core/yaml_map_reader.h"

namespace pvcap::sim {

namespace {

// The simulated Morph (sim: sensel:).
SimSenselConfig parse_sim_sensel(const YAML::Node& sn, const std::filesystem::path& file) {
  SimSenselConfig c;
  MapReader sr(sn, file, "sim.sensel");
  sr.get("transport", c.transport);
  if (c.transport != "pty" && c.transport != "usb")
    sr.fail(sn["transport"], "transport", fmt::format("'{}' is not pty or usb", c.transport));
  sr.get_in_range("press_x_mm", c.press_x_mm, 0.0, 230.0);
  sr.get_in_range("press_y_mm", c.press_y_mm, 0.0, 130.0);
  sr.get_in_range("peak_grams", c.peak_grams, 0.0, 4000.0);
  sr.get_in_range("period_s", c.period_s, 0.1, 1000.0);
  sr.get_in_range("clock_start_us", c.clock_start_us, 0.0, 4294967295.0);
  sr.get_in_range("drift_ppm", c.drift_ppm, -10000.0, 10000.0);
  sr.get_in_range("usb_jitter_mean_ms", c.usb_jitter_mean_ms, 0.0, 100.0);
  sr.get_in_range("usb_jitter_max_ms", c.usb_jitter_max_ms, 0.0, 1000.0);
  sr.get_in_range("drop_fraction", c.drop_fraction, 0.0, 0.5);
  sr.get_in_range("clock_reset_at_s", c.clock_reset_at_s, 0.0, 1e7);
  sr.get_in_range("unplug_at_s", c.unplug_at_s, 0.0, 1e7);
  sr.get_in_range("replug_after_s", c.replug_after_s, 0.0, 1e7);
  if (c.replug_after_s) {
    if (!c.unplug_at_s) sr.fail(sn["replug_after_s"], "replug_after_s", "needs an unplug_at_s before it");
    if (c.transport != "pty")
      sr.fail(sn["replug_after_s"], "replug_after_s", "a Sensel plugged back in is emulated on transport: pty only");
  }
  if (sr.has("replug_serial")) {
    std::string v;
    sr.get("replug_serial", v);
    c.replug_serial = v;
  }
  if (sr.has("replug_renamed")) {
    sr.get("replug_renamed", c.replug_renamed);
    if (!c.replug_after_s) sr.fail(sn["replug_renamed"], "replug_renamed", "needs a replug_after_s before it");
  }
  sr.finish();
  return c;
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
      cr.get_in_range("exposure_wobble_us", c.exposure_wobble_us, 0.0, 1e6);
      cr.get_in_range("drift_ppm", c.drift_ppm, -10000.0, 10000.0);
      cr.get_in_range("jitter_us", c.jitter_us, 0.0, 1e6);
      cr.get_in_range("packet_loss", c.packet_loss, 0.0, 1.0);
      cr.get_in_range("stop_after_s", c.stop_after_s, 0.0, 1e7);
      cr.get_in_range("return_after_s", c.return_after_s, 0.0, 1e7);
      if (c.return_after_s && (!c.stop_after_s || *c.return_after_s <= *c.stop_after_s))
        cr.fail(cams[i]["return_after_s"], "return_after_s", "needs a stop_after_s before it");
      cr.get_in_range("outages", c.outages, 1, 10000);
      cr.get_in_range("outage_every_s", c.outage_every_s, 0.0, 1e7);
      if (c.outages > 1 && (!c.return_after_s || c.outage_every_s <= *c.return_after_s - *c.stop_after_s))
        cr.fail(cams[i]["outages"], "outages",
                "more than one needs a return_after_s and an outage_every_s longer than the outage");
      cr.get("trigger_line", c.trigger_line);
      if (cr.has("node_map")) {
        std::string naming;
        cr.get("node_map", naming);
        if (naming != "aravis" && naming != "sfnc2" && naming != "raw")
          cr.fail(cams[i]["node_map"], "node_map",
                  "expected aravis (the fake camera's names), sfnc2 or raw (an exposure in the camera's own steps)");
        c.node_map = naming == "sfnc2" ? NodeMapNaming::Sfnc2
                     : naming == "raw" ? NodeMapNaming::RawExposure
                                       : NodeMapNaming::Aravis;
      }
      cr.get("white_balance_auto", c.white_balance_auto);
      if (c.white_balance_auto && c.node_map != NodeMapNaming::Sfnc2)
        cr.fail(cams[i]["white_balance_auto"], "white_balance_auto", "needs node_map: sfnc2 (the map that has it)");
      cr.get_in_range("ptp_lock_after_s", c.ptp_lock_after_s, 0.0, 3600.0);
      cr.get_in_range("ptp_servo_error_ns", c.ptp_servo_error_ns, 0.0, 1e9);
      cr.get_in_range("ptp_unlock_at_s", c.ptp_unlock_at_s, 0.0, 1e7);
      cr.get_in_range("ptp_unlock_for_s", c.ptp_unlock_for_s, 0.0, 1e7);
      for (const char* key : {"ptp_lock_after_s", "ptp_servo_error_ns", "ptp_unlock_at_s", "ptp_unlock_for_s"})
        if (cr.has(key) && c.node_map != NodeMapNaming::Sfnc2)
          cr.fail(cams[i][key], key, "needs node_map: sfnc2 (the map with the PTP features)");
      cr.get_numbers("position_mm", c.position_mm);
      cr.get_numbers("look_at_mm", c.look_at_mm);
      cr.get_in_range("focal_px", c.focal_px, 50.0, 100000.0);
      cr.get_numbers("distortion", c.distortion);
      if (c.position_mm && (*c.position_mm)[2] <= 0)
        cr.fail(cams[i]["position_mm"], "position_mm", "the camera must stand above the pad (z > 0 mm)");
      cr.finish();
      s.cameras.push_back(c);
    }
  } else {
    s.cameras.resize(n_cameras);
  }
  if (const YAML::Node sn = r.child("sensel")) s.sensel = parse_sim_sensel(sn, file);
  r.finish();
  return s;
}

}  // namespace

std::optional<SimConfig> load_sim_config(const RigConfig& rig) {
  if (!rig.simulated) return std::nullopt;
  const YAML::Node root = load_yaml(rig.text, rig.source);
  try {
    return parse_sim(root["sim"], rig.source, rig.cameras.size());
  } catch (const YAML::Exception& e) {
    throw UserError(fmt::format("{}:{}: {}", rig.source.string(), e.mark.line + 1, e.msg));
  }
}

}  // namespace pvcap::sim
