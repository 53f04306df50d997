#pragma once
// The report's plots as inline SVG (no script, nothing fetched): a line plot of series over session
// time, a histogram as bars, and the protocol's takes on a timeline. Each returns the <svg> element
// (or a note when there is nothing to plot) for report/report_html.cpp's sections.
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace pvcap::report {

struct Series {
  std::vector<std::pair<double, double>> points;
  std::string colour, name;
};

// Every series over one pair of axes; `marks` are red vertical lines (drops); `yrange` fixes the
// y axis (values beyond it are drawn at its edge).
std::string line_plot(const std::vector<Series>& series, const std::string& xlabel, const std::string& ylabel,
                      const std::vector<double>& marks = {}, std::optional<std::pair<double, double>> yrange = {});
// A histogram as the report's JSON gives it ({"lo", "hi", "counts", "below", "above"}).
std::string bar_plot(const nlohmann::json& histogram, const std::string& xlabel, const std::string& colour = "#1f77b4");
// The takes (start_s, end_s, hand, status, sequence) as bars, the left hand below, the right above.
std::string takes_timeline(const nlohmann::json& takes, double duration_s);

}  // namespace pvcap::report
