#include "codec/sensel_units.h"

#include <cmath>
#include <map>
#include <mutex>

namespace pvcap::sensel {

std::array<double, 4> upsampling_weights(double t) {
  std::array<double, 4> w{};
  for (int k = 0; k <= 3000; ++k) {
    const double s = -1.0 + k * 0.001;
    const double d = t - s;
    if (std::abs(d) >= 1.0) continue;
    const double window = (1.0 - d * d) * (1.0 - d * d);
    for (int tap = 0; tap < 4; ++tap) {
      const double centre = tap - 1;  // taps at offsets -1, 0, 1, 2 from the segment start
      const double tent = std::max(0.0, 1.0 - std::abs(s - centre));
      w[std::size_t(tap)] += tent * window;
    }
  }
  const double sum = w[0] + w[1] + w[2] + w[3];
  for (double& v : w) v /= sum;
  return w;
}

namespace {

// Output sample o of an axis with `n` source cells and factor `scale` -> (first tap index, weights).
struct Plan {
  std::vector<int> first;
  std::vector<std::array<double, 4>> weights;
};

const Plan& plan_for(int n, int scale) {
  static std::mutex mu;
  static std::map<std::pair<int, int>, Plan> cache;
  std::lock_guard lock(mu);
  auto [it, fresh] = cache.try_emplace({n, scale});
  if (fresh) {
    Plan& p = it->second;
    for (int seg = 0; seg < n - 1; ++seg) {
      const int last_step = seg == n - 2 ? scale : scale - 1;  // the last segment also emits step = scale
      for (int step = 0; step <= last_step; ++step) {
        p.first.push_back(seg - 1);
        p.weights.push_back(upsampling_weights(double(step) / scale));
      }
    }
  }
  return it->second;
}

}  // namespace

std::vector<float> upsample(const std::vector<std::uint16_t>& counts, const Grid& g) {
  const Plan& px = plan_for(g.cols, g.xscale);
  const Plan& py = plan_for(g.rows, g.yscale);
  const int out_w = int(px.first.size()), out_h = int(py.first.size());
  // Along x: rows x out_w.
  std::vector<double> tmp(std::size_t(g.rows) * std::size_t(out_w), 0.0);
  for (int r = 0; r < g.rows; ++r)
    for (int o = 0; o < out_w; ++o) {
      double acc = 0;
      for (int k = 0; k < 4; ++k) {
        const int c = px.first[std::size_t(o)] + k;
        if (c >= 0 && c < g.cols)
          acc += px.weights[std::size_t(o)][std::size_t(k)] * counts[std::size_t(r * g.cols + c)];
      }
      tmp[std::size_t(r * out_w + o)] = acc;
    }
  // Along y.
  std::vector<float> out(std::size_t(out_h) * std::size_t(out_w), 0.0f);
  for (int o = 0; o < out_h; ++o)
    for (int x = 0; x < out_w; ++x) {
      double acc = 0;
      for (int k = 0; k < 4; ++k) {
        const int r = py.first[std::size_t(o)] + k;
        if (r >= 0 && r < g.rows) acc += py.weights[std::size_t(o)][std::size_t(k)] * tmp[std::size_t(r * out_w + x)];
      }
      out[std::size_t(o * out_w + x)] = float(acc);
    }
  return out;
}

PressureSummary summarize_pressure(const std::vector<std::uint16_t>& counts, const Grid& g, double contact_kpa,
                                   int unit_shift) {
  PressureSummary s;
  if (g.cells() <= 0 || counts.size() != std::size_t(g.cells())) return s;
  const double cell_w = kSenselPitchMm * g.xscale, cell_h = kSenselPitchMm * g.yscale;
  double sum = 0, sx = 0, sy = 0;
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) {
      const double v = counts[std::size_t(r * g.cols + c)];
      if (v <= 0) continue;
      sum += v;
      sx += v * c * cell_w;
      sy += v * r * cell_h;
      if (native_cell_kpa(v, g, unit_shift) > contact_kpa) ++s.contact_cells;
    }
  s.total_newtons = grams_to_newtons(counts_to_grams(sum, unit_shift));
  s.contact_area_mm2 = s.contact_cells * cell_w * cell_h;
  if (sum > 0) {
    s.centroid_x_mm = sx / sum;
    s.centroid_y_mm = sy / sum;
  }
  return s;
}

}  // namespace pvcap::sensel
