#include "report/ptp_time.h"

#include <cmath>
#include <set>
#include <string>

#include "report/report_numbers.h"

namespace pvcap::report {

using json = nlohmann::json;

std::optional<json> ptp_time_section(const std::vector<EventRecord>& events, std::int64_t start_ns) {
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
      if (const auto o = j.find("offset_ns"); o != j.end() && o->is_number())
        worst = std::max(worst, std::abs(o->get<double>()));
      if (const auto g = j.find("grandmaster"); g != j.end() && g->is_string()) grandmasters.insert(g->get<std::string>());
      if (const auto p = j.find("port_state"); p != j.end() && p->is_string()) port_states.insert(p->get<std::string>());
    } else if (e.kind == "ptp_host_out_of_time") {
      ++out;
      const double t = round_to(seconds(e.host_ns, start_ns), 1e-3);
      // Seconds in a row (readings a second apart, give or take a late one) are one stretch.
      if (!stretches.empty() && t - stretches.back()["to_s"].get<double>() <= 1.6) {
        stretches.back()["to_s"] = t;
        stretches.back()["seconds"] = stretches.back()["seconds"].get<int>() + 1;
        stretches.back()["why"] = e.message;  // the last reason given
      } else {
        stretches.push_back({{"from_s", t}, {"to_s", t}, {"seconds", 1}, {"why", e.message}});
      }
    }
  }
  if (readings == 0 && out == 0) return std::nullopt;
  return json{{"readings", readings},
              {"in_time", in_time},
              {"seconds_out_of_time", out},
              {"worst_offset_ns", worst},
              {"grandmasters", grandmasters},
              {"port_states", port_states},
              {"out_of_time", stretches}};
}

}  // namespace pvcap::report
