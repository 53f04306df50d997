#include "report/takes_sections.h"

#include <algorithm>
#include <optional>
#include <utility>

#include "core/result.h"
#include "core/rig_config.h"
#include "protocol/takes.h"
#include "report/report_numbers.h"

namespace pvcap::report {

using nlohmann::json;

json protocol_section(const std::filesystem::path& dir, std::int64_t start_ns) {
  json out = {{"takes", json::array()}};
  auto t = protocol::read_takes(dir);
  if (!t) {
    // No protocol run, or a folder it continues moved: a note. A disk that failed a read: the report fails.
    if (t.error().disk_failed) throw UserError(t.error().message);
    out["note"] = t.error().message;
    return out;
  }
  if (t.value().takes.empty()) {
    out["note"] = "no protocol was run in this session";
    return out;
  }
  const json all = protocol::takes_json(t.value());
  int lighting_flagged = 0;
  out["plan_steps"] = t.value().plan_steps;
  out["by_force"] = all.value("by_force", json::object());
  out["protocol"] = t.value().protocol_start.value("protocol", "");
  const std::string here = std::filesystem::absolute(dir).lexically_normal().string();
  for (const auto& take : t.value().takes) {
    json j = {{"step", take.step},
              {"sequence", take.sequence},
              {"action", take.action},
              {"hand", take.hand},
              {"force", take.force},
              {"status", take.status},
              {"repetitions", take.repetitions},
              {"mean_newtons", round_to(take.mean_newtons, 1e-4)},
              {"peak_newtons", round_to(take.peak_newtons, 1e-4)}};
    if (take.check_ok) j["check_ok"] = *take.check_ok;
    if (!take.check_problems.empty()) j["check_problems"] = take.check_problems;
    // The lighting commanded and the lighting the images showed; a take they disagree on is flagged,
    // naming the lights (docs/lighting.md).
    if (!take.lighting_commanded.empty()) {
      j["lighting"] = {{"commanded", take.lighting_commanded},
                       {"seen", take.lighting_seen},
                       {"flagged", !take.lights_disagreeing.empty()},
                       {"lights", take.lights_disagreeing}};
      if (!take.lights_disagreeing.empty()) ++lighting_flagged;
    }
    const bool this_folder = std::filesystem::absolute(take.session).lexically_normal().string() == here;
    j["this_session"] = this_folder;
    if (this_folder && take.start_ns) j["start_s"] = round_to(seconds(*take.start_ns, start_ns), 1e-3);
    if (this_folder && take.end_ns) j["end_s"] = round_to(seconds(*take.end_ns, start_ns), 1e-3);
    out["takes"].push_back(std::move(j));
  }
  out["lighting_flagged_takes"] = lighting_flagged;
  return out;
}

// The rig's lights (docs/lighting.md): the light check's finding per light, and every switch with
// what the images said of it (confirmed, how late); nullopt for a session that switched no lights.
namespace {

// A frame taken this soon after a command may show either side of the switch.
constexpr std::int64_t kLineSettleNs = 100'000'000;

// Each camera's frames with their line levels (where its chunks gave them) against the steady lights
// it drives as commanded: how many frames were checked and how many disagreed, the first one's time.
json line_levels(SessionReader& r, const std::vector<std::pair<std::int64_t, std::string>>& commands,
                 std::int64_t start_ns) {
  json out = json::array();
  if (commands.empty()) return out;
  RigConfig rig;
  try {
    rig = parse_rig_config(r.info().rig_config, r.info().rig_path);
  } catch (const std::exception&) {
    return out;  // a rig this pvcap cannot read: its lights are unknown
  }
  for (const CameraInfo& cam : r.cameras()) {
    std::vector<const LightConfig*> lights;
    std::string names;
    for (const LightConfig& l : rig.lights)
      if (l.camera == cam.name && !l.strobe && line_number(l.line) >= 0) lights.push_back(&l), names += l.name;
    if (lights.empty()) continue;
    auto frames = r.frame_timing(cam.device_id);
    if (!frames) throw UserError(frames.error().message);
    std::uint64_t checked = 0, disagreeing = 0;
    std::optional<std::int64_t> first;
    for (const FrameTiming& f : frames.value()) {
      if (!f.good || !f.chunk_line_status) continue;
      const auto after = std::upper_bound(commands.begin(), commands.end(), f.host_ns,
                                          [](std::int64_t t, const auto& c) { return t < c.first; });
      if (after == commands.begin() || f.host_ns - (after - 1)->first < kLineSettleNs) continue;
      const std::string& code = (after - 1)->second;
      ++checked;
      const bool agrees = std::all_of(lights.begin(), lights.end(), [&](const LightConfig* l) {
        const bool high = (*f.chunk_line_status >> line_number(l->line)) & 1;
        return high == (code.find(l->name) != std::string::npos);
      });
      if (!agrees && !first) first = f.host_ns;
      disagreeing += !agrees;
    }
    if (checked == 0) continue;
    json entry = {{"camera", cam.name}, {"lights", names}, {"frames_checked", checked}, {"disagreeing", disagreeing}};
    if (first) entry["first_disagreement_s"] = round_to(seconds(*first, start_ns), 1e-3);
    out.push_back(std::move(entry));
  }
  return out;
}

}  // namespace

std::optional<json> lighting_section(SessionReader& r, std::int64_t start_ns) {
  auto events = r.protocol_events();
  if (!events) throw UserError(events.error().message);
  json out = {{"switches", json::array()}, {"late", 0}, {"unconfirmed", 0}};
  std::vector<std::pair<std::int64_t, std::string>> commands;  // each command's time and code, in order
  bool any = false;
  for (const auto& e : events.value()) {
    auto d = json::parse(e.detail, nullptr, false);
    if (d.is_discarded() || !d.is_object()) continue;
    if (e.kind == "light_check") {
      any = true;
      out["check"] = {{"lights", d.value("lights", json::array())},
                      {"problems", d.value("problems", json::array())},
                      {"at_s", round_to(seconds(e.host_ns, start_ns), 1e-3)}};
    } else if (e.kind == "lighting_seen") {
      any = true;
      json sw = {{"code", d.value("code", "")},
                 {"from", d.value("from", "")},
                 {"at_s", round_to(seconds(e.host_ns, start_ns), 1e-3)},
                 {"confirmed", d.value("confirmed", false)}};
      for (const char* k : {"delay_ms", "frames", "on_time", "superseded", "cameras_waiting"})
        if (d.contains(k)) sw[k] = d[k];
      if (sw["confirmed"].get<bool>() && !d.value("on_time", true)) out["late"] = out["late"].get<int>() + 1;
      if (!sw["confirmed"].get<bool>() && !d.value("superseded", false))
        out["unconfirmed"] = out["unconfirmed"].get<int>() + 1;
      out["switches"].push_back(std::move(sw));
    } else if (e.kind == "lighting") {
      any = true;
      commands.emplace_back(e.host_ns, d.value("code", ""));
    }
  }
  if (!any) return std::nullopt;
  if (json lines = line_levels(r, commands, start_ns); !lines.empty()) out["lines"] = std::move(lines);
  return out;
}

}  // namespace pvcap::report
