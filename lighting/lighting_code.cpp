#include "lighting/lighting_code.h"

#include <algorithm>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace pvcap::lighting {

Result<std::uint32_t> parse_lighting(const std::string& code, const LightNames& names) {
  if (code == "none" || code == "off") return std::uint32_t{0};
  std::uint32_t mask = 0;
  for (char c : code) {
    if (c == '-') continue;
    bool found = false;
    for (std::size_t i = 0; i < names.size(); ++i)
      if (names[i] == std::string(1, c)) {
        mask |= 1u << i;
        found = true;
      }
    if (!found)
      return Error{names.empty() ? fmt::format("lighting '{}': the rig file names no lights (lights:)", code)
                                 : fmt::format("lighting '{}': the rig has no light '{}' (its lights: {})", code,
                                               std::string(1, c), fmt::join(names, ", "))};
  }
  return mask;
}

std::string lighting_code(std::uint32_t mask, const LightNames& names) {
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i) out += (mask >> i & 1u) ? names[i] : "-";
  return out;
}

bool same_lighting(const std::string& a, const std::string& b) {
  const auto letters = [](const std::string& code) {
    std::string l;
    if (code == "none" || code == "off") return l;
    for (char c : code)
      if (c != '-') l += c;
    std::sort(l.begin(), l.end());
    return l;
  };
  return letters(a) == letters(b);
}

}  // namespace pvcap::lighting
