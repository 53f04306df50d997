#include "sim/replay_rig.h"

#include <fstream>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "core/rig_config.h"
#include "sim/session_replay.h"
#include "storage/index/session_reader.h"

namespace pvcap::sim {

Result<ReplayRig> write_replay_rig(const std::filesystem::path& session_dir, std::filesystem::path out, double rate) {
  const std::filesystem::path dir = std::filesystem::absolute(session_dir).lexically_normal();
  auto replay = SessionReplay::open(dir, rate);  // what the devices will read: readable now, or said now
  if (!replay) return replay.error();
  auto reader = SessionReader::open(dir);
  if (!reader) return reader.error();
  const std::string text = reader.value()->info().rig_config;
  YAML::Node rig;
  try {
    rig = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    return Error{fmt::format("{}: the rig file stored with the session cannot be read: {}", dir.string(), e.what())};
  }
  if (!rig.IsMap() || !rig["cameras"] || !rig["cameras"].IsSequence())
    return Error{fmt::format("{}: the rig file stored with the session has no cameras", dir.string())};

  rig["name"] = fmt::format("{}-replay", rig["name"] ? rig["name"].as<std::string>() : std::string("rig"));
  // The cameras on the simulator's loopback addresses. Hardware-triggered ones stay so: the replay's
  // trigger line pulses as each recorded frame falls due (sim/replay_camera.h). The others free-run,
  // paced by the replay (a software trigger's timing would be the new recorder's, not the session's).
  for (std::size_t i = 0; i < rig["cameras"].size(); ++i) {
    YAML::Node cam = rig["cameras"][i];
    const std::string address = cam["address"] ? cam["address"].as<std::string>() : std::string();
    if (address.rfind("127.", 0) != 0) cam["address"] = fmt::format("127.0.0.{}", 2 + i);
    const bool hardware = cam["trigger"] && cam["trigger"].as<std::string>() == "hardware";
    if (hardware) {
      cam["trigger_source"] = "Line0";  // the simulated camera's line
    } else {
      cam["trigger"] = "free-run";
      cam.remove("trigger_source");
    }
  }
  if (rig["sensel"]) {
    rig["sensel"].remove("usb");
    rig["sensel"]["tty"] = "sim";
  }
  rig.remove("sim");
  rig["sim"]["replay"] = dir.string();
  rig["sim"]["replay_rate"] = rate;

  if (out.empty()) out = std::filesystem::current_path() / (dir.filename().string() + "-replay.yaml");
  YAML::Emitter e;
  e << rig;
  const std::string yaml = fmt::format(
      "# Re-serves the recorded session {} through the simulated devices (pvcap replay --as-devices).\n"
      "# Record it again with: pvcap session --rig {}\n{}\n",
      dir.string(), out.string(), e.c_str());
  try {
    (void)parse_rig_config(yaml, out);  // what the session will read: valid now, or said now
  } catch (const UserError& err) {
    return Error{fmt::format("the replay rig for {} is not valid: {}", dir.string(), err.what())};
  }
  {
    std::ofstream f(out);
    f << yaml;
    if (!f.flush()) return Error{fmt::format("cannot write {}", out.string())};
  }
  ReplayRig r;
  r.rig_file = out;
  std::int64_t first = INT64_MAX, last = INT64_MIN, last_camera = INT64_MIN;
  for (std::size_t c = 0; c < rig["cameras"].size(); ++c)
    if (auto i = replay.value()->camera_index(rig["cameras"][c]["name"].as<std::string>())) {
      const auto& frames = replay.value()->camera_frames(i.value());
      if (frames.empty()) continue;
      first = std::min(first, frames.front().t_ns);
      last_camera = std::max(last_camera, frames.back().t_ns);
    }
  last = last_camera;
  for (const auto& p : replay.value()->pressure_frames()) {
    first = std::min(first, p.t_ns);
    last = std::max(last, p.t_ns);
  }
  r.session_seconds = last > first ? double(last - first) / 1e9 : 0;
  r.replay_seconds = r.session_seconds / rate;
  const std::int64_t record_end = last_camera > first ? last_camera : last;  // a Sensel-only session: all of it
  r.record_seconds = record_end > first ? double(record_end - first) / 1e9 / rate : 0;
  return r;
}

}  // namespace pvcap::sim
