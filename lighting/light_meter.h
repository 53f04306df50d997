#pragma once
// The light meter: how bright a camera's frame is where the room's light shows and the hand does
// not, read from a sparse grid of its pixels on the camera's worker thread (about 4,000 of them: a
// few microseconds a frame), never on the capture thread.
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

namespace pvcap::lighting {

struct Point {
  double x = 0, y = 0;
};

// Which pixels a camera's levels are read from: a grid whose step is odd (every Bayer colour is in
// it), in regions of the image (3 x 3: a lamp to one side brightens one side of every view more than
// the other, which one mean over the view would not tell), without the pad and a margin around it
// where the pad's corners in the image are known (the pad calibration's): the hand works there and
// would hide a lamp's change.
inline constexpr int kMeterColumns = 3, kMeterRows = 3, kMeterRegions = kMeterColumns * kMeterRows;
struct MeterGrid {
  std::vector<std::vector<std::size_t>> regions;  // per region, the byte offsets of its pixels
  int bytes_per_pixel = 1;
};
MeterGrid meter_grid(int width, int height, int bytes_per_pixel,
                     const std::optional<std::array<Point, 4>>& pad_corners_px = std::nullopt);

// Each region's mean, in the pixels' own unit (8-bit, 16-bit little-endian, or the mean of three 8-bit
// channels); NaN for a region with too few pixels off the pad; empty when the frame is smaller than
// the grid asks.
std::vector<double> meter_levels(const std::uint8_t* data, std::size_t size, const MeterGrid& grid);

// A level as it would read at the reference exposure and gain: light is proportional to exposure
// time and to the gain's linear factor (gain in dB), so a lamp's step is not confused with either.
double normalised_level(double level, double exposure_us, double gain_db, double reference_exposure_us,
                        double reference_gain_db);

}  // namespace pvcap::lighting
