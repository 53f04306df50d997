#include "lighting/light_meter.h"

#include <algorithm>
#include <cmath>

namespace pvcap::lighting {

namespace {
// Inside the quadrilateral (any winding): the same side of every edge.
bool inside(const std::array<Point, 4>& q, double x, double y) {
  int sign = 0;
  for (std::size_t i = 0; i < 4; ++i) {
    const Point& a = q[i];
    const Point& b = q[(i + 1) % 4];
    const double cross = (b.x - a.x) * (y - a.y) - (b.y - a.y) * (x - a.x);
    const int s = cross > 0 ? 1 : cross < 0 ? -1 : 0;
    if (s == 0) continue;
    if (sign == 0) sign = s;
    if (s != sign) return false;
  }
  return true;
}
}  // namespace

MeterGrid meter_grid(int width, int height, int bytes_per_pixel, const std::optional<std::array<Point, 4>>& pad) {
  MeterGrid g;
  g.bytes_per_pixel = std::max(1, bytes_per_pixel);
  g.regions.assign(kMeterRegions, {});
  if (width <= 0 || height <= 0) return g;
  int step = std::max(3, int(std::sqrt(double(width) * height / 4000.0)));
  if (step % 2 == 0) ++step;
  // The pad and a margin of a quarter of its size around it (the hand, the forearm over its edge).
  std::optional<std::array<Point, 4>> keep_out;
  if (pad) {
    Point c;
    for (const Point& p : *pad) c.x += p.x / 4, c.y += p.y / 4;
    std::array<Point, 4> grown{};
    for (std::size_t i = 0; i < 4; ++i)
      grown[i] = {c.x + 1.25 * ((*pad)[i].x - c.x), c.y + 1.25 * ((*pad)[i].y - c.y)};
    keep_out = grown;
  }
  std::size_t kept = 0;
  for (int y = step / 2; y < height; y += step)
    for (int x = step / 2; x < width; x += step) {
      if (keep_out && inside(*keep_out, x, y)) continue;
      const int region = std::min(kMeterRows - 1, y * kMeterRows / height) * kMeterColumns +
                         std::min(kMeterColumns - 1, x * kMeterColumns / width);
      g.regions[std::size_t(region)].push_back((std::size_t(y) * std::size_t(width) + std::size_t(x)) *
                                               std::size_t(g.bytes_per_pixel));
      ++kept;
    }
  // A pad that fills the view leaves too little: then the whole view, hand and all.
  if (keep_out && kept < 400) return meter_grid(width, height, bytes_per_pixel, std::nullopt);
  return g;
}

std::vector<double> meter_levels(const std::uint8_t* data, std::size_t size, const MeterGrid& grid) {
  std::vector<double> out;
  if (!data) return out;
  for (const auto& region : grid.regions) {
    if (region.size() < 30) {
      out.push_back(std::nan(""));
      continue;
    }
    if (region.back() + std::size_t(grid.bytes_per_pixel) > size) return {};
    std::uint64_t sum = 0;
    switch (grid.bytes_per_pixel) {
      case 1:
        for (std::size_t o : region) sum += data[o];
        break;
      case 2:
        for (std::size_t o : region) sum += std::uint32_t(data[o]) | std::uint32_t(data[o + 1]) << 8;
        break;
      default:
        for (std::size_t o : region) sum += (std::uint32_t(data[o]) + data[o + 1] + data[o + 2]) / 3;
    }
    out.push_back(double(sum) / double(region.size()));
  }
  return out;
}

double normalised_level(double level, double exposure_us, double gain_db, double reference_exposure_us,
                        double reference_gain_db) {
  if (exposure_us <= 0 || reference_exposure_us <= 0) return level;
  return level * (reference_exposure_us / exposure_us) * std::pow(10.0, (reference_gain_db - gain_db) / 20.0);
}

}  // namespace pvcap::lighting
