#include "core/fault_injection.h"

#include <cstdlib>
#include <map>
#include <sstream>

#include <fmt/format.h>

namespace pvcap {

FaultPlan parse_faults(std::string_view spec, std::vector<std::string>& problems) {
  std::map<std::string, double, std::less<>> values;
  std::stringstream in{std::string(spec)};
  std::string item;
  FaultPlan plan;
  while (std::getline(in, item, ',')) {
    const auto eq = item.find('=');
    if (eq == std::string::npos) {
      problems.push_back(fmt::format("PVCAP_FAULTS: '{}' is not name=value; ignored", item));
      continue;
    }
    if (item.substr(0, eq) == "sim.light_off") {  // names, not a number
      plan.sim_light_off = item.substr(eq + 1);
      continue;
    }
    char* end = nullptr;
    const std::string number = item.substr(eq + 1);
    const double v = std::strtod(number.c_str(), &end);
    if (end == number.c_str() || *end != '\0') {
      problems.push_back(fmt::format("PVCAP_FAULTS: '{}' has no number after '='; ignored", item));
      continue;
    }
    values[item.substr(0, eq)] = v;
  }
  plan.spec = std::string(spec);
  auto take = [&](const char* name) -> std::optional<double> {
    auto it = values.find(name);
    if (it == values.end()) return std::nullopt;
    const double v = it->second;
    values.erase(it);
    return v;
  };
  auto stall = [&](const char* seconds, const char* after) -> std::optional<Stall> {
    const auto s = take(seconds);
    const auto a = take(after);
    if (!s) return std::nullopt;
    return Stall{*s, a.value_or(2.0)};
  };
  auto count = [&](const char* name) -> std::optional<std::size_t> {
    const auto v = take(name);
    if (!v) return std::nullopt;
    return std::size_t(std::max(1.0, *v));
  };
  plan.camera_pipeline_stall = stall("camera_pipeline.stall_s", "camera_pipeline.stall_after_s");
  plan.stall_camera = int(take("camera_pipeline.stall_camera").value_or(0));
  plan.sensel_pipeline_stall = stall("sensel_pipeline.stall_s", "sensel_pipeline.stall_after_s");
  plan.index_writer_stall = stall("index_writer.stall_s", "index_writer.stall_after_s");
  plan.sensel_queue_frames = count("sensel.queue_frames");
  plan.index_queue_records = count("index_writer.queue_records");
  plan.index_overflow_memory_records = count("index_writer.overflow_memory_records");
  plan.encoder_frame_delay =
      std::chrono::milliseconds(std::int64_t(std::max(0.0, take("encoder.frame_delay_ms").value_or(0))));
  plan.encoder_stall = stall("encoder.stall_s", "encoder.stall_after_s");
  plan.realign_stall_s = std::max(0.0, take("realign.stall_s").value_or(0));
  plan.report_stall_s = std::max(0.0, take("report.stall_s").value_or(0));
  plan.recover_stall_s = std::max(0.0, take("recover.stall_s").value_or(0));
  plan.camera_stop_stall_s = std::max(0.0, take("camera.stop_stall_s").value_or(0));
  plan.sim_light_lag_s = std::max(0.0, take("sim.light_lag_s").value_or(0));
  for (const auto& [name, v] : values)
    problems.push_back(fmt::format("PVCAP_FAULTS: '{}' is not a fault; ignored", name));
  return plan;
}

}  // namespace pvcap
