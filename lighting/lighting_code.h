#pragma once
// A lighting condition's code, as PressureVision names it (`--lighting LCR`): the letters of the
// lights that are on, in the rig's order, '-' for each light that is off ("LCR", "L-R", "---").
// Lights are the rig file's `lights:` (core/rig_config.h); a mask holds bit i for its light i.
#include <cstdint>
#include <string>
#include <vector>

#include "core/result.h"

namespace pvcap::lighting {

// The rig's lights' letters, in order.
using LightNames = std::vector<std::string>;

// Reads a code against the rig's lights: "LCR", "L-R", "LR" (the letters on, in any order), or
// "-"/"none"/"off" (all off). An Error names the letter the rig has no light for.
Result<std::uint32_t> parse_lighting(const std::string& code, const LightNames& names);
// The code of `mask`: every light's letter when on, '-' when off (one character each).
std::string lighting_code(std::uint32_t mask, const LightNames& names);
// Two codes name the same lights on, whatever their form ("L-R", "LR", "RL"; "---", "none").
bool same_lighting(const std::string& a, const std::string& b);
// Every light on.
inline std::uint32_t all_lights(const LightNames& names) { return (1u << names.size()) - 1u; }

}  // namespace pvcap::lighting
