#include "calib/pad_layout.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/aruco.hpp>

namespace pvcap::calib {

std::array<cv::Point2d, 4> PadLayout::grid_corners_mm() const {
  const double x0 = -0.5 * pitch_mm, y0 = -0.5 * pitch_mm;
  const double x1 = (cols - 0.5) * pitch_mm, y1 = (rows - 0.5) * pitch_mm;
  return {{{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}};
}

std::array<cv::Point2d, 4> PadLayout::marker_corners_mm(const PadMarker& m) const {
  const double h = m.size_mm / 2;
  const cv::Point2d c = m.centre_mm;
  return {{{c.x - h, c.y - h}, {c.x + h, c.y - h}, {c.x + h, c.y + h}, {c.x - h, c.y + h}}};
}

const PadMarker* PadLayout::marker(int id) const {
  for (const PadMarker& m : markers)
    if (m.id == id) return &m;
  return nullptr;
}

PadLayout default_pad_layout() {
  PadLayout p;
  p.dictionary = cv::aruco::DICT_4X4_50;
  const double s = 28.0, left = -27.0, right = 257.0, top = -27.0, bottom = 157.0;
  p.markers = {{0, {left, top}, s},    {1, {77.0, top}, s},     {2, {153.0, top}, s},    {3, {right, top}, s},
               {4, {right, 65.0}, s},  {5, {right, bottom}, s}, {6, {153.0, bottom}, s}, {7, {77.0, bottom}, s},
               {8, {left, bottom}, s}, {9, {left, 65.0}, s}};
  return p;
}

void to_json(nlohmann::json& j, const PadLayout& p) {
  j = {{"name", p.name},
       {"cols", p.cols},
       {"rows", p.rows},
       {"pitch_mm", p.pitch_mm},
       {"origin", "centre of cell (0,0); x along columns, y along rows, z into the pad"},
       {"body_margin_mm", p.body_margin_mm},
       {"mat_mm", {p.mat_mm.x, p.mat_mm.y, p.mat_mm.width, p.mat_mm.height}},
       {"dictionary", p.dictionary}};
  for (const PadMarker& m : p.markers)
    j["markers"].push_back({{"id", m.id}, {"centre_mm", {m.centre_mm.x, m.centre_mm.y}}, {"size_mm", m.size_mm}});
}

namespace {
// A number in [lo, hi], or an error naming the key (never a silent wrap from a huge value).
double number(const nlohmann::json& j, const char* key, double lo, double hi) {
  const double v = j.at(key).get<double>();
  if (!(v >= lo && v <= hi))
    throw nlohmann::json::other_error::create(501, fmt::format("{} must be in [{}, {}]", key, lo, hi), &j);
  return v;
}
}  // namespace

void from_json(const nlohmann::json& j, PadLayout& p) {
  p = PadLayout{};
  p.name = j.at("name").get<std::string>();
  p.cols = int(number(j, "cols", 2, 10000));
  p.rows = int(number(j, "rows", 2, 10000));
  p.pitch_mm = number(j, "pitch_mm", 1e-3, 100);
  p.body_margin_mm = j.contains("body_margin_mm") ? number(j, "body_margin_mm", 0, 1000) : p.body_margin_mm;
  if (j.contains("mat_mm")) {
    const auto m = j.at("mat_mm").get<std::vector<double>>();
    if (m.size() != 4 || !std::all_of(m.begin(), m.end(), [](double v) { return std::abs(v) < 1e5; }) || m[2] <= 0 ||
        m[3] <= 0)
      throw nlohmann::json::other_error::create(501, "mat_mm must be [x, y, width, height] in mm", &j);
    p.mat_mm = {m[0], m[1], m[2], m[3]};
  }
  p.dictionary = int(number(j, "dictionary", 0, cv::aruco::DICT_APRILTAG_36h11));
  for (const auto& m : j.at("markers")) {
    const auto c = m.at("centre_mm").get<std::vector<double>>();
    if (c.size() != 2 || !(std::abs(c[0]) < 1e5 && std::abs(c[1]) < 1e5))
      throw nlohmann::json::other_error::create(501, "a marker's centre_mm must be [x, y] in mm", &m);
    p.markers.push_back({int(number(m, "id", 0, 999)), {c[0], c[1]}, number(m, "size_mm", 1e-3, 1e4)});
  }
}

}  // namespace pvcap::calib
