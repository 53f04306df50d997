// The lighting library on synthetic levels: codes, the meter's regions off the pad, the light check's
// model and what it says of a switch (lighting/).
#include <gtest/gtest.h>

#include <cmath>

#include "lighting/light_meter.h"
#include "lighting/light_model.h"
#include "lighting/light_monitor.h"
#include "lighting/lighting_code.h"

using namespace pvcap::lighting;

TEST(LightingCode, CodesReadInTheRigsOrderAndALightItLacksIsNamed) {
  const LightNames names = {"L", "C", "R"};
  EXPECT_EQ(parse_lighting("LCR", names).value(), 0b111u);
  EXPECT_EQ(parse_lighting("L-R", names).value(), 0b101u);
  EXPECT_EQ(parse_lighting("RL", names).value(), 0b101u);
  EXPECT_EQ(parse_lighting("---", names).value(), 0u);
  EXPECT_EQ(parse_lighting("none", names).value(), 0u);
  auto bad = parse_lighting("LXR", names);
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().message, "lighting 'LXR': the rig has no light 'X' (its lights: L, C, R)");
  EXPECT_NE(parse_lighting("L", {}).error().message.find("names no lights"), std::string::npos);
  EXPECT_EQ(lighting_code(0b101u, names), "L-R");
  EXPECT_EQ(lighting_code(0b010u, names), "-C-");
  EXPECT_EQ(lighting_code(all_lights(names), names), "LCR");
}

TEST(LightMeter, RegionsTellTheSidesOfTheViewApartAndLeaveThePadOut) {
  const int w = 300, h = 210;
  std::vector<std::uint8_t> image(std::size_t(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) image[std::size_t(y) * w + std::size_t(x)] = x < w / 3 ? 40 : x >= 2 * w / 3 ? 200 : 120;
  const MeterGrid whole = meter_grid(w, h, 1);
  ASSERT_EQ(whole.regions.size(), std::size_t(kMeterRegions));
  const auto levels = meter_levels(image.data(), image.size(), whole);
  ASSERT_EQ(levels.size(), std::size_t(kMeterRegions));
  for (int r = 0; r < kMeterRows; ++r) {
    EXPECT_NEAR(levels[std::size_t(r * kMeterColumns)], 40, 1e-9);
    EXPECT_NEAR(levels[std::size_t(r * kMeterColumns + 1)], 120, 1e-9);
    EXPECT_NEAR(levels[std::size_t(r * kMeterColumns + 2)], 200, 1e-9);
  }
  // The pad in the middle (and a quarter of its size around it) is not read: no pixel of the grid
  // lies there, and the middle region, all pad, reads nothing.
  const std::array<Point, 4> pad = {Point{105, 75}, Point{195, 75}, Point{195, 135}, Point{105, 135}};
  const MeterGrid off_pad = meter_grid(w, h, 1, pad);
  for (const auto& region : off_pad.regions)
    for (std::size_t o : region) {
      const double x = double(o % std::size_t(w)), y = double(o / std::size_t(w));
      EXPECT_FALSE(x > 94 && x < 206 && y > 68 && y < 142) << x << "," << y;
    }
  EXPECT_TRUE(std::isnan(meter_levels(image.data(), image.size(), off_pad)[4]));
  // A frame shorter than the grid reads nothing; a level is brought to the reference exposure and gain.
  EXPECT_TRUE(meter_levels(image.data(), 100, whole).empty());
  EXPECT_NEAR(normalised_level(50, 5000, 0, 10000, 0), 100, 1e-9);
  EXPECT_NEAR(normalised_level(100, 10000, 6.0206, 10000, 0), 50, 1e-3);
}

namespace {
// Two cameras of two regions each: L lights the left regions, R the right ones, C a little of both;
// a fourth light D adds nothing anywhere (a dead lamp).
LightModel model_of_four() {
  const LightNames names = {"L", "C", "R", "D"};
  const std::vector<double> dark = {20, 22, 18, 25}, noise = {0.5, 0.5, 0.5, 0.5};
  const std::vector<std::vector<double>> alone = {
      {60, 30, 50, 32}, {30, 32, 28, 35}, {25, 70, 22, 65}, {20, 22, 18, 25}};
  return learn_light_model(names, dark, noise, alone);
}
}  // namespace

TEST(LightModel, EachCombinationOfSeenLightsIsToldApartAndADeadLampIsNeverSaidOn) {
  const LightModel m = model_of_four();
  EXPECT_TRUE(m.seen(0) && m.seen(1) && m.seen(2));
  EXPECT_FALSE(m.seen(3));
  EXPECT_EQ(m.seen_mask(), 0b0111u);
  for (std::uint32_t mask = 0; mask < 16; ++mask) {
    std::vector<double> levels;
    for (std::size_t c = 0; c < 4; ++c) levels.push_back(m.predicted(c, mask) + (c % 2 ? 0.3 : -0.3));
    EXPECT_EQ(m.classify(levels), mask & 0b0111u) << "mask " << mask;
  }
  // A channel without a frame (NaN) is left out, not read as dark.
  std::vector<double> partial = {m.predicted(0, 0b001), NAN, m.predicted(2, 0b001), m.predicted(3, 0b001)};
  EXPECT_EQ(m.classify(partial), 0b001u);
  // A lamp seen in one region only, or darkening one, is not seen: a noisy region, not a lamp.
  LightModel one_region = m;
  for (auto& c : one_region.contribution) c[3] = 0;
  one_region.contribution[1][3] = 6;
  one_region.contribution[2][3] = -3;
  EXPECT_FALSE(one_region.seen(3));
  one_region.contribution[3][3] = 4;
  EXPECT_TRUE(one_region.seen(3)) << "two regions that brighten";
  // The model survives its JSON (the light_check event).
  LightModel back = nlohmann::json(m).get<LightModel>();
  EXPECT_EQ(back.names, m.names);
  EXPECT_EQ(back.contribution, m.contribution);
}

TEST(LightMonitor, ASwitchIsConfirmedAtTheFirstOfTwoFramesShowingItAndCountsTheFramesBefore) {
  const LightModel m = model_of_four();
  LightMonitor monitor(4);
  const std::int64_t command = 1'000'000'000, period = 33'000'000;
  // From L alone to R alone: camera 0 (channels 0, 1) shows it from its 2nd frame after the command,
  // camera 1 (channels 2, 3) from its 4th (a slow lamp, or a slow camera).
  for (int k = 0; k < 10; ++k) {
    const std::int64_t t = command + 5'000'000 + k * period;
    for (std::size_t c = 0; c < 4; ++c) {
      const bool shows_new = c < 2 ? k >= 1 : k >= 3;
      monitor.add(c, t, m.predicted(c, shows_new ? 0b100u : 0b001u));
    }
  }
  const auto seen = switch_seen(m, monitor, command, 0b001u, 0b100u, command + 10 * period, 2);
  EXPECT_TRUE(seen.confirmed);
  EXPECT_TRUE(seen.visible);
  EXPECT_EQ(seen.frames, 3);
  EXPECT_NEAR(seen.delay_ms, (5'000'000 + 3 * period) / 1e6, 1e-6);
  // Before camera 1 showed it: not yet, and camera 1 (its first channel, 2) is the one waiting.
  const auto early = switch_seen(m, monitor, command, 0b001u, 0b100u, command + 3 * period, 2);
  EXPECT_FALSE(early.confirmed);
  ASSERT_EQ(early.channels_waiting.size(), 1u);
  EXPECT_EQ(early.channels_waiting[0], 2);
  // A switch of the dead lamp alone changes nothing any camera can see.
  const auto dead = switch_seen(m, monitor, command, 0b001u, 0b1001u, command + 10 * period, 2);
  EXPECT_FALSE(dead.visible);
  EXPECT_FALSE(dead.confirmed);
  // Medians per channel, and their spread.
  std::vector<double> spread;
  const auto med = monitor.medians(command + 4 * period, command + 11 * period, &spread);
  EXPECT_NEAR(med[2], m.predicted(2, 0b100u), 1e-9);
  EXPECT_NEAR(spread[2], 0, 1e-9);
}
