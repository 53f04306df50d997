#include "calib/pad_layout.h"

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
  p.markers = {{0, {left, top}, s},      {1, {77.0, top}, s},    {2, {153.0, top}, s},   {3, {right, top}, s},
               {4, {right, 65.0}, s},    {5, {right, bottom}, s}, {6, {153.0, bottom}, s}, {7, {77.0, bottom}, s},
               {8, {left, bottom}, s},   {9, {left, 65.0}, s}};
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

void from_json(const nlohmann::json& j, PadLayout& p) {
  p = PadLayout{};
  p.name = j.at("name").get<std::string>();
  p.cols = j.at("cols").get<int>();
  p.rows = j.at("rows").get<int>();
  p.pitch_mm = j.at("pitch_mm").get<double>();
  p.body_margin_mm = j.value("body_margin_mm", p.body_margin_mm);
  if (j.contains("mat_mm")) {
    const auto& m = j.at("mat_mm");
    p.mat_mm = {m.at(0).get<double>(), m.at(1).get<double>(), m.at(2).get<double>(), m.at(3).get<double>()};
  }
  p.dictionary = j.at("dictionary").get<int>();
  for (const auto& m : j.at("markers"))
    p.markers.push_back({m.at("id").get<int>(),
                         {m.at("centre_mm").at(0).get<double>(), m.at("centre_mm").at(1).get<double>()},
                         m.at("size_mm").get<double>()});
}

}  // namespace pvcap::calib
