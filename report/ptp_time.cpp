#include "report/ptp_time.h"

#include <cmath>
#include <set>
#include <string>

#include "report/report_numbers.h"

namespace pvcap::report {

using json = nlohmann::json;

namespace {

// Seconds in a row (readings a second apart, give or take a late one) are one stretch.
void add_second(json& stretches, double t, const std::string& why) {
  if (!stretches.empty() && t - stretches.back()["to_s"].get<double>() <= 1.6) {
    stretches.back()["to_s"] = t;
    stretches.back()["seconds"] = stretches.back()["seconds"].get<int>() + 1;
    stretches.back()["why"] = why;  // the last reason given
  } else {
    stretches.push_back({{"from_s", t}, {"to_s", t}, {"seconds", 1}, {"why", why}});
  }
}

double number_or(const json& j, const char* key, double fallback) {
  const auto v = j.find(key);
  return v != j.end() && v->is_number() ? v->get<double>() : fallback;
}

// Each camera's PTP readings and seconds out of lock.
json cameras_section(const std::vector<EventRecord>& events, std::int64_t start_ns,
                     const std::map<std::int64_t, std::string>& names) {
  struct Tally {
    int readings = 0, locked = 0, out = 0;
    double worst = 0;
    json stretches = json::array();
  };
  std::map<std::int64_t, Tally> by_device;
  for (const EventRecord& e : events) {
    if (!e.device_id || (e.kind != "ptp_camera_state" && e.kind != "ptp_camera_out_of_lock")) continue;
    Tally& t = by_device[*e.device_id];
    if (e.kind == "ptp_camera_out_of_lock") {
      ++t.out;
      add_second(t.stretches, round_to(seconds(e.host_ns, start_ns), 1e-3), e.message);
      continue;
    }
    ++t.readings;
    const json j = json::parse(e.message, nullptr, false);
    if (j.is_discarded() || !j.is_object()) continue;
    const auto locked = j.find("locked");
    if (locked == j.end() || !locked->is_boolean() || !locked->get<bool>()) continue;
    ++t.locked;
    t.worst = std::max(t.worst, std::abs(number_or(j, "offset_ns", 0)));
  }
  json out = json::array();
  for (const auto& [device, t] : by_device) {
    const auto name = names.find(device);
    out.push_back({{"name", name != names.end() ? name->second : "device " + std::to_string(device)},
                   {"readings", t.readings},
                   {"locked", t.locked},
                   {"seconds_out_of_lock", t.out},
                   {"worst_offset_ns", t.worst},
                   {"out_of_lock", t.stretches}});
  }
  return out;
}

}  // namespace

std::optional<json> ptp_time_section(const std::vector<EventRecord>& events, std::int64_t start_ns,
                                     const std::map<std::int64_t, std::string>& camera_names) {
  int readings = 0, in_time = 0, out = 0;
  double worst = 0;
  std::set<std::string> grandmasters, port_states;
  json stretches = json::array();
  for (const EventRecord& e : events) {
    if (e.kind == "ptp_host_state") {
      ++readings;
      const json j = json::parse(e.message, nullptr, false);
      if (j.is_discarded() || !j.is_object()) continue;
      if (const auto t = j.find("in_time"); t != j.end() && t->is_boolean() && t->get<bool>()) ++in_time;
      worst = std::max(worst, std::abs(number_or(j, "offset_ns", 0)));
      if (const auto g = j.find("grandmaster"); g != j.end() && g->is_string()) grandmasters.insert(g->get<std::string>());
      if (const auto p = j.find("port_state"); p != j.end() && p->is_string()) port_states.insert(p->get<std::string>());
    } else if (e.kind == "ptp_host_out_of_time") {
      ++out;
      add_second(stretches, round_to(seconds(e.host_ns, start_ns), 1e-3), e.message);
    }
  }
  json cameras = cameras_section(events, start_ns, camera_names);
  if (readings == 0 && out == 0 && cameras.empty()) return std::nullopt;
  json section = {{"cameras", cameras}};
  if (readings == 0 && out == 0) return section;  // the cameras on PTP, the host not read
  section.update(json{{"readings", readings},
              {"in_time", in_time},
              {"seconds_out_of_time", out},
              {"worst_offset_ns", worst},
              {"grandmasters", grandmasters},
              {"port_states", port_states},
              {"out_of_time", stretches}});
  return section;
}

}  // namespace pvcap::report
