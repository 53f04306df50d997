#include "report/svg_plots.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "report/report_html.h"

namespace pvcap::report {

namespace {

using nlohmann::json;

// A "nice" tick step for a span: 1, 2 or 5 times a power of ten, about `ticks` of them.
double tick_step(double span, int ticks) {
  if (span <= 0) return 1;
  const double raw = span / ticks, p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (raw <= m * p) return m * p;
  return 10 * p;
}

struct Frame {
  double x0, x1, y0, y1;  // data ranges
  int w = 520, h = 170, left = 56, right = 10, top = 8, bottom = 30;
  double px(double x) const { return left + (x - x0) / (x1 - x0) * (w - left - right); }
  double py(double y) const { return h - bottom - (y - y0) / (y1 - y0) * (h - top - bottom); }
};

// Axes, ticks and labels; the plot's content goes between open and close.
std::string axes(const Frame& f, const std::string& xlabel, const std::string& ylabel) {
  std::string s = fmt::format(
      "<svg xmlns='http://www.w3.org/2000/svg' width='{}' height='{}' viewBox='0 0 {} {}' role='img'>"
      "<rect x='{}' y='{}' width='{}' height='{}' fill='#fff' stroke='#999'/>",
      f.w, f.h, f.w, f.h, f.left, f.top, f.w - f.left - f.right, f.h - f.top - f.bottom);
  const double xs = tick_step(f.x1 - f.x0, 8), ys = tick_step(f.y1 - f.y0, 4);
  for (double x = std::ceil(f.x0 / xs) * xs; x <= f.x1 + 1e-9; x += xs)
    s += fmt::format(
        "<line x1='{0:.1f}' x2='{0:.1f}' y1='{1}' y2='{2}' stroke='#eee'/><text x='{0:.1f}' y='{3}' "
        "font-size='10' text-anchor='middle'>{4:g}</text>",
        f.px(x), f.top, f.h - f.bottom, f.h - f.bottom + 12, std::round(x / xs) * xs + 0.0);
  for (double y = std::ceil(f.y0 / ys) * ys; y <= f.y1 + 1e-9; y += ys)
    s += fmt::format(
        "<line x1='{0}' x2='{1}' y1='{2:.1f}' y2='{2:.1f}' stroke='#eee'/><text x='{3}' y='{4:.1f}' "
        "font-size='10' text-anchor='end'>{5:g}</text>",
        f.left, f.w - f.right, f.py(y), f.left - 4, f.py(y) + 3, std::round(y / ys) * ys + 0.0);
  s += fmt::format("<text x='{}' y='{}' font-size='11' text-anchor='middle'>{}</text>", (f.left + f.w - f.right) / 2,
                   f.h - 3, html_escape(xlabel));
  s += fmt::format("<text x='12' y='{}' font-size='11' text-anchor='middle' transform='rotate(-90 12 {})'>{}</text>",
                   (f.top + f.h - f.bottom) / 2, (f.top + f.h - f.bottom) / 2, html_escape(ylabel));
  return s;
}

const char* status_colour(const std::string& status) {
  if (status == "done") return "#2ca02c";
  if (status == "bad") return "#d62728";
  if (status == "superseded") return "#9467bd";
  if (status == "skipped") return "#7f7f7f";
  return "#ff7f0e";  // interrupted
}

}  // namespace

std::string line_plot(const std::vector<Series>& series, const std::string& xlabel, const std::string& ylabel,
                      const std::vector<double>& marks, std::optional<std::pair<double, double>> yrange) {
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const auto& s : series)
    for (const auto& [x, y] : s.points)
      x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
  for (double m : marks) x0 = std::min(x0, m), x1 = std::max(x1, m);
  if (x0 > x1) return "<p class='note'>no data</p>";
  if (yrange) y0 = yrange->first, y1 = yrange->second;
  if (x1 - x0 < 1e-9) x0 -= 0.5, x1 += 0.5;
  if (y1 - y0 < 1e-9) y0 -= 0.5, y1 += 0.5;
  const double pad = (y1 - y0) * 0.05;
  Frame f{x0, x1, y0 - pad, y1 + pad};
  std::string s = axes(f, xlabel, ylabel);
  for (double m : marks)
    s += fmt::format("<line x1='{0:.1f}' x2='{0:.1f}' y1='{1}' y2='{2}' stroke='#d62728' stroke-width='1.5'/>", f.px(m),
                     f.top, f.h - f.bottom);
  for (const auto& se : series) {
    std::string d;
    for (const auto& [x, y] : se.points)
      d += fmt::format("{}{:.1f},{:.1f}", d.empty() ? "M" : " L", f.px(x), f.py(std::clamp(y, f.y0, f.y1)));
    s += fmt::format("<path d='{}' fill='none' stroke='{}' stroke-width='1'><title>{}</title></path>", d, se.colour,
                     html_escape(se.name));
  }
  return s + "</svg>";
}

std::string bar_plot(const json& h, const std::string& xlabel, const std::string& colour) {
  const auto counts = h.at("counts").get<std::vector<double>>();
  if (counts.empty()) return "<p class='note'>no data</p>";
  const double lo = h.at("lo"), hi = h.at("hi"), top = std::max(1.0, *std::max_element(counts.begin(), counts.end()));
  Frame f{lo, hi, 0, top * 1.05};
  std::string s = axes(f, xlabel, "count");
  const double w = (hi - lo) / double(counts.size());
  for (std::size_t i = 0; i < counts.size(); ++i) {
    if (counts[i] <= 0) continue;
    const double x = lo + w * double(i);
    s += fmt::format(
        "<rect x='{:.1f}' y='{:.1f}' width='{:.1f}' height='{:.1f}' fill='{}'><title>{:g}..{:g}: "
        "{:g}</title></rect>",
        f.px(x), f.py(counts[i]), std::max(1.0, f.px(x + w) - f.px(x) - 0.5), f.py(0) - f.py(counts[i]), colour, x,
        x + w, counts[i]);
  }
  s += "</svg>";
  const std::uint64_t below = h.value("below", 0), above = h.value("above", 0);
  if (below + above)
    s += fmt::format("<p class='note'>{} below {:.3g}, {} above {:.3g} (outside the plot)</p>", below, lo, above, hi);
  return s;
}

std::string takes_timeline(const json& takes, double duration_s) {
  double end = duration_s;
  for (const auto& t : takes)
    if (t.contains("end_s")) end = std::max(end, t["end_s"].get<double>());
  if (end <= 0) return "";
  Frame f{0, end, 0, 1};
  f.h = 90;
  f.bottom = 30;
  std::string s = axes(f, "session time (s)", "");
  for (const auto& t : takes) {
    if (!t.contains("start_s") || !t.contains("end_s")) continue;
    const double a = t["start_s"], b = t["end_s"];
    const bool right = t.value("hand", "") == "right";
    const double y0 = right ? 0.5 : 0.05, y1 = right ? 0.95 : 0.5;
    s += fmt::format(
        "<rect x='{:.1f}' y='{:.1f}' width='{:.1f}' height='{:.1f}' fill='{}' stroke='#333' "
        "stroke-width='0.5'><title>{} ({}): {:.1f}-{:.1f} s</title></rect>",
        f.px(a), f.py(y1), std::max(1.0, f.px(b) - f.px(a)), f.py(y0) - f.py(y1), status_colour(t.value("status", "")),
        html_escape(t.value("sequence", "")), html_escape(t.value("status", "")), a, b);
  }
  s += fmt::format(
      "<text x='{}' y='{:.1f}' font-size='10' text-anchor='end'>left</text><text x='{}' y='{:.1f}' "
      "font-size='10' text-anchor='end'>right</text>",
      f.left - 4, f.py(0.25) + 3, f.left - 4, f.py(0.75) + 3);
  return s + "</svg>";
}

}  // namespace pvcap::report
