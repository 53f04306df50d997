#include "report/sync_self_check.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <fmt/format.h>

namespace pvcap::report {

namespace {

// A press's signals scaled to [0, 1] (pressure by its peak, image change by its range).
struct Scaled {
  std::vector<TimedValue> pressure, image;
};

std::optional<Scaled> scale(const PressSignals& p) {
  if (p.pressure.size() < 4 || p.image.size() < 4) return std::nullopt;
  double peak = 0, lo = p.image.front().value, hi = lo;
  for (const auto& v : p.pressure) peak = std::max(peak, v.value);
  for (const auto& v : p.image) lo = std::min(lo, v.value), hi = std::max(hi, v.value);
  if (peak <= 0 || hi - lo <= 1e-9) return std::nullopt;
  Scaled s;
  for (const auto& v : p.pressure) s.pressure.push_back({v.t_ns, v.value / peak});
  for (const auto& v : p.image) s.image.push_back({v.t_ns, (v.value - lo) / (hi - lo)});
  return s;
}

// Linear interpolation, held at the ends.
double at(const std::vector<TimedValue>& p, double t_ns) {
  if (t_ns <= double(p.front().t_ns)) return p.front().value;
  if (t_ns >= double(p.back().t_ns)) return p.back().value;
  auto it =
      std::upper_bound(p.begin(), p.end(), t_ns, [](double t, const TimedValue& v) { return t < double(v.t_ns); });
  const TimedValue& b = *it;
  const TimedValue& a = *(it - 1);
  const double span = double(b.t_ns - a.t_ns);
  return span <= 0 ? b.value : a.value + (b.value - a.value) * (t_ns - double(a.t_ns)) / span;
}

// Least-squares cubic y = c0 + c1 x + c2 x^2 + c3 x^3 through the points (zeros when degenerate).
std::array<double, 4> fit_cubic(const std::vector<std::pair<double, double>>& xy) {
  constexpr int n = 4;
  double a[n][n + 1] = {};
  for (const auto& [x, y] : xy) {
    double p[n] = {1, x, x * x, x * x * x};
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) a[i][j] += p[i] * p[j];
      a[i][n] += p[i] * y;
    }
  }
  // Gaussian elimination with partial pivoting.
  for (int c = 0; c < n; ++c) {
    int pivot = c;
    for (int r = c + 1; r < n; ++r)
      if (std::abs(a[r][c]) > std::abs(a[pivot][c])) pivot = r;
    std::swap(a[c], a[pivot]);
    if (std::abs(a[c][c]) < 1e-12) return {0, 0, 0, 0};
    for (int r = c + 1; r < n; ++r) {
      const double f = a[r][c] / a[c][c];
      for (int k = c; k <= n; ++k) a[r][k] -= f * a[c][k];
    }
  }
  std::array<double, 4> coef{};
  for (int r = n - 1; r >= 0; --r) {
    double v = a[r][n];
    for (int k = r + 1; k < n; ++k) v -= a[r][k] * coef[std::size_t(k)];
    coef[std::size_t(r)] = v / a[r][r];
  }
  return coef;
}

double cubic_at(const std::array<double, 4>& c, double x) { return c[0] + x * (c[1] + x * (c[2] + x * c[3])); }

// Mean square residual of the best cubic through the points.
double cubic_residual(const std::vector<std::pair<double, double>>& xy) {
  if (xy.empty()) return 0;
  const auto c = fit_cubic(xy);
  double sse = 0;
  for (const auto& [x, y] : xy) sse += (y - cubic_at(c, x)) * (y - cubic_at(c, x));
  return sse / double(xy.size());
}

// The frames on a press's flanks: image change between 25 % and 95 % of its range, where it moves
// with the pressure (below, a fingertip appears or leaves at once; above, it barely changes).
bool on_flank(double scaled_image) { return scaled_image >= 0.25 && scaled_image <= 0.95; }

// (pressure at the frame's time minus the offset, image change) for one press's flank frames.
void flank_points(const Scaled& press, double offset_ms, std::vector<std::pair<double, double>>& xy) {
  for (const auto& v : press.image)
    if (on_flank(v.value)) xy.emplace_back(at(press.pressure, double(v.t_ns) - offset_ms * 1e6), v.value);
}

double residual(const std::vector<Scaled>& presses, const std::vector<std::size_t>& use, double offset_ms) {
  std::vector<std::pair<double, double>> xy;
  for (std::size_t k : use) flank_points(presses[k], offset_ms, xy);
  return cubic_residual(xy);
}

// Presses that disagree with the rest at `offset_ms` (a press window that caught something else:
// the hand arriving mid-press, frames of a stalled camera): their mean square distance from the
// pooled curve is more than 4 times the median press's (and above 0.02^2, a visible misfit).
// The curve is fitted to `fit`'s presses and every press of `use` is judged against it.
std::vector<std::size_t> consistent_presses(const std::vector<Scaled>& presses, const std::vector<std::size_t>& fit,
                                            const std::vector<std::size_t>& use, double offset_ms) {
  std::vector<std::pair<double, double>> xy;
  for (std::size_t k : fit) flank_points(presses[k], offset_ms, xy);
  const auto curve = fit_cubic(xy);
  std::vector<double> misfit;
  for (std::size_t k : use) {
    std::vector<std::pair<double, double>> own;
    flank_points(presses[k], offset_ms, own);
    double sse = 0;
    for (const auto& [x, y] : own) sse += (y - cubic_at(curve, x)) * (y - cubic_at(curve, x));
    misfit.push_back(own.empty() ? 0.0 : sse / double(own.size()));
  }
  std::vector<double> sorted = misfit;
  std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(sorted.size() / 2), sorted.end());
  const double limit = std::max(4 * sorted[sorted.size() / 2], 0.02 * 0.02);
  std::vector<std::size_t> kept;
  for (std::size_t i = 0; i < use.size(); ++i)
    if (misfit[i] <= limit) kept.push_back(use[i]);
  return kept;
}

struct Search {
  double offset_ms = 0;
  bool at_edge = false;
  double contrast = 0;  // residual a few ms either side of the minimum over the minimum
};

Search search(const std::vector<Scaled>& presses, const std::vector<std::size_t>& use, const SelfCheckOptions& o) {
  const int n = int(std::lround(o.search_ms / o.step_ms));
  std::vector<double> r(std::size_t(2 * n + 1));
  for (int i = -n; i <= n; ++i) r[std::size_t(i + n)] = residual(presses, use, i * o.step_ms);
  const std::size_t best = std::size_t(std::min_element(r.begin(), r.end()) - r.begin());
  Search s;
  s.at_edge = best == 0 || best + 1 == r.size();
  // A parabola through the residuals within 4 ms of the minimum: the residual is noisy at the
  // scale of single frames, its trend is not.
  const int half = std::max(2, int(std::lround(4.0 / o.step_ms)));
  double sx[5] = {0, 0, 0, 0, 0}, sy[3] = {0, 0, 0};
  for (int i = std::max(0, int(best) - half); i <= std::min(int(r.size()) - 1, int(best) + half); ++i) {
    const double x = (i - n) * o.step_ms, y = r[std::size_t(i)];
    double p = 1;
    for (int k = 0; k < 5; ++k) sx[k] += p, p *= x;
    sy[0] += y, sy[1] += y * x, sy[2] += y * x * x;
  }
  // Normal equations for y = a + b x + c x^2.
  const double m[3][3] = {{sx[0], sx[1], sx[2]}, {sx[1], sx[2], sx[3]}, {sx[2], sx[3], sx[4]}};
  auto det3 = [](const double a[3][3]) {
    return a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
           a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
  };
  const double d = det3(m);
  s.offset_ms = (int(best) - n) * o.step_ms;
  if (std::abs(d) > 1e-12) {
    double mb[3][3], mc[3][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) mb[i][j] = j == 1 ? sy[i] : m[i][j], mc[i][j] = j == 2 ? sy[i] : m[i][j];
    const double b = det3(mb) / d, c = det3(mc) / d;
    const double vertex = -b / (2 * c);
    if (c > 0 && std::abs(vertex - s.offset_ms) <= half * o.step_ms) s.offset_ms = vertex;
  }
  const std::size_t away = std::size_t(std::lround(8.0 / o.step_ms));
  const double lo = r[best] + 1e-12;
  const double left = best >= away ? r[best - away] : r.front(),
               right = best + away < r.size() ? r[best + away] : r.back();
  s.contrast = std::min(left, right) / lo;
  return s;
}

}  // namespace

OffsetEstimate estimate_offset(const std::vector<PressSignals>& presses, const SelfCheckOptions& o) {
  OffsetEstimate e;
  std::vector<Scaled> scaled;
  for (const auto& p : presses)
    if (auto s = scale(p)) scaled.push_back(std::move(*s));
  e.presses_used = int(scaled.size());
  if (e.presses_used < o.min_presses) {
    e.verdict =
        fmt::format("too few presses to tell: {} seen by this camera, {} needed", e.presses_used, o.min_presses);
    return e;
  }
  std::vector<std::size_t> all(scaled.size());
  for (std::size_t k = 0; k < all.size(); ++k) all[k] = k;
  // Once with every press; the presses that disagree with the rest are set aside, and every press is
  // judged again against the curve of those that agree (a bad press skews the first curve, and
  // with it the verdict on some good ones).
  const std::vector<std::size_t> first = consistent_presses(scaled, all, all, search(scaled, all, o).offset_ms);
  all = consistent_presses(scaled, first, all, search(scaled, first, o).offset_ms);
  e.presses_rejected = int(scaled.size() - all.size());
  e.presses_used = int(all.size());
  if (e.presses_used < o.min_presses) {
    e.verdict =
        fmt::format("too few presses to tell: {} agree with each other, {} needed", e.presses_used, o.min_presses);
    return e;
  }
  const Search s = search(scaled, all, o);
  if (s.at_edge) {
    e.verdict =
        fmt::format("no clear offset within +-{:.0f} ms: the image change does not follow the pressure", o.search_ms);
    return e;
  }
  if (s.contrast < 1.2) {
    e.verdict = "inconclusive: the image change follows the pressure about as well at any nearby offset";
    return e;
  }
  // Jackknife over presses: leave each out, estimate again.
  std::vector<double> loo;
  for (std::size_t k = 0; k < all.size(); ++k) {
    std::vector<std::size_t> use;
    for (std::size_t j : all)
      if (j != k) use.push_back(j);
    loo.push_back(search(scaled, use, o).offset_ms);
  }
  double mean = 0;
  for (double v : loo) mean += v;
  mean /= double(loo.size());
  double ss = 0;
  for (double v : loo) ss += (v - mean) * (v - mean);
  const double n = double(loo.size());
  e.offset_ms = s.offset_ms;
  // The grid and the parabola resolve about a tenth of a step, whatever the spread says.
  e.uncertainty_ms = std::max(std::sqrt((n - 1) / n * ss), 0.1 * o.step_ms);
  e.verdict = "ok";
  return e;
}

}  // namespace pvcap::report
