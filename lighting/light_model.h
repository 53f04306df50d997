#pragma once
// What each light adds to each channel's level (a region of a camera's view, lighting/light_meter.h), learnt by the light check at a session's start (every
// light off, then each on alone), and the lighting a set of levels shows: the lights whose sum,
// over the dark level, fits every camera's level best. A light that no camera sees come on (a lamp
// that failed, a line wired to nothing) is not in any code the images show.
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lighting/lighting_code.h"

namespace pvcap::lighting {

struct LightModel {
  LightNames names;
  std::vector<double> dark;                       // per channel: its level with every light off
  std::vector<double> noise;                      // per channel: its level's spread frame to frame
  std::vector<std::vector<double>> contribution;  // [channel][light]: what the light adds

  // A step a camera tells from its noise: at least 4 times it and one level.
  bool visible(std::size_t camera, double step) const;
  // The cameras see the light come on: it adds at least 2 levels, beyond the noise, in two regions.
  bool seen(std::size_t light) const;
  std::uint32_t seen_mask() const;
  // The level camera `camera` shows under `mask`.
  double predicted(std::size_t camera, std::uint32_t mask) const;
  // The lights the levels show (one per camera; NaN where a camera has none): the seen lights'
  // combination that fits best, scaled by each camera's noise.
  std::uint32_t classify(const std::vector<double>& levels) const;
};

void to_json(nlohmann::json& j, const LightModel& m);
void from_json(const nlohmann::json& j, LightModel& m);

// The model from the light check's medians: `dark` and `noise` per camera with every light off,
// `alone[light][camera]` with that light on alone.
LightModel learn_light_model(const LightNames& names, const std::vector<double>& dark,
                             const std::vector<double>& noise, const std::vector<std::vector<double>>& alone);

}  // namespace pvcap::lighting
