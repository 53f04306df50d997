#include "calib/board_views_file.h"

#include <cmath>
#include <fstream>
#include <iterator>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

namespace pvcap::calib {

// One view a line: `- {ids: [...], xy: [x0, y0, x1, y1, ...]}`, coordinates to 1/1000 px (the
// corners' own error is a hundred times that).
Status save_board_views(const std::filesystem::path& file, const BoardViews& v) {
  std::string out =
      fmt::format("pvcap_board_views: 1\nimage_size: [{}, {}]\nviews:\n", v.image_size.width, v.image_size.height);
  for (const BoardView& view : v.views) {
    out += "  - {ids: [";
    for (std::size_t k = 0; k < view.ids.size(); ++k) out += fmt::format("{}{}", k ? ", " : "", view.ids[k]);
    out += "], xy: [";
    for (std::size_t k = 0; k < view.corners.size(); ++k)
      out += fmt::format("{}{:.3f}, {:.3f}", k ? ", " : "", view.corners[k].x, view.corners[k].y);
    out += "]}\n";
  }
  const std::filesystem::path tmp = file.string() + ".tmp";
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    f << out;
    if (!f.flush()) return Error{fmt::format("{}: cannot write the board views", tmp.string())};
  }
  std::error_code ec;
  std::filesystem::rename(tmp, file, ec);
  if (ec) return Error{fmt::format("{}: cannot write the board views: {}", file.string(), ec.message())};
  return {};
}

Result<BoardViews> load_board_views(const std::filesystem::path& file) {
  std::ifstream f(file, std::ios::binary);
  if (!f) return Error{fmt::format("{}: cannot read the board views", file.string())};
  const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  return parse_board_views(text, file.string());
}

Result<BoardViews> parse_board_views(const std::string& text, const std::string& source) {
  const auto bad = [&](const std::string& why) {
    return Error{fmt::format("{}: not a board views file: {}", source, why)};
  };
  try {
    const YAML::Node root = YAML::Load(text);
    if (!root.IsMap() || !root["pvcap_board_views"] || root["pvcap_board_views"].as<int>() != 1)
      return bad("no `pvcap_board_views: 1`");
    BoardViews out;
    if (!root["image_size"] || !root["image_size"].IsSequence()) return bad("no image_size");
    const auto size = root["image_size"].as<std::vector<int>>();
    if (size.size() != 2 || size[0] <= 0 || size[1] <= 0 || size[0] > 65535 || size[1] > 65535)
      return bad("image_size is not [width, height]");
    out.image_size = {size[0], size[1]};
    const YAML::Node views = root["views"];
    if (!views.IsSequence()) return bad("views is not a list");
    for (std::size_t i = 0; i < views.size(); ++i) {
      if (!views[i].IsMap() || !views[i]["ids"] || !views[i]["xy"])
        return bad(fmt::format("view {} has no ids and xy", i));
      BoardView view;
      view.ids = views[i]["ids"].as<std::vector<int>>();
      const auto xy = views[i]["xy"].as<std::vector<float>>();
      if (xy.size() != 2 * view.ids.size())
        return bad(fmt::format("view {} has {} ids but {} coordinates", i, view.ids.size(), xy.size()));
      for (std::size_t k = 0; k < view.ids.size(); ++k) {
        if (!std::isfinite(xy[2 * k]) || !std::isfinite(xy[2 * k + 1]) || view.ids[k] < 0)
          return bad(fmt::format("view {} corner {} is not a corner", i, k));
        view.corners.emplace_back(xy[2 * k], xy[2 * k + 1]);
      }
      out.views.push_back(std::move(view));
    }
    return out;
  } catch (const YAML::Exception& e) {
    return bad(e.what());
  }
}

}  // namespace pvcap::calib
