#include "core/fault_injection.h"

#include <cstdlib>
#include <map>
#include <mutex>
#include <sstream>
#include <string>

#include <spdlog/spdlog.h>

namespace pvcap::fault {

namespace {

std::map<std::string, double, std::less<>> parse(const char* spec) {
  std::map<std::string, double, std::less<>> out;
  std::stringstream in(spec);
  std::string item;
  while (std::getline(in, item, ',')) {
    const auto eq = item.find('=');
    if (eq == std::string::npos) {
      spdlog::warn("PVCAP_FAULTS: '{}' is not name=value; ignored", item);
      continue;
    }
    char* end = nullptr;
    const std::string number = item.substr(eq + 1);
    const double v = std::strtod(number.c_str(), &end);
    if (end == number.c_str() || *end != '\0') {
      spdlog::warn("PVCAP_FAULTS: '{}' has no number after '='; ignored", item);
      continue;
    }
    out[item.substr(0, eq)] = v;
  }
  return out;
}

const std::map<std::string, double, std::less<>>& faults() {
  static const auto parsed = [] {
    const char* spec = std::getenv("PVCAP_FAULTS");
    if (!spec || !*spec) return std::map<std::string, double, std::less<>>{};
    spdlog::warn("PVCAP_FAULTS is set ({}): faults are injected on purpose, for tests; never on a real session",
                 spec);
    return parse(spec);
  }();
  return parsed;
}

}  // namespace

std::optional<double> value(std::string_view name) {
  const auto& f = faults();
  auto it = f.find(name);
  if (it == f.end()) return std::nullopt;
  return it->second;
}

}  // namespace pvcap::fault
