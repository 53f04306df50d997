#include "storage/video/bayer_tiles.h"

#include <algorithm>
#include <charconv>

#include <fmt/format.h>

namespace pvcap {

namespace {
// The most tiles up to `wanted` that cut `length` into equal, even parts.
int divisions(int length, int wanted) {
  for (int n = std::max(1, wanted); n > 1; --n)
    if (length % n == 0 && (length / n) % 2 == 0) return n;
  return 1;
}

// Where plane `k` of tile `t` lies in the whole mosaic's stacked planes.
cv::Rect plane_rect(const TileGrid& g, int t, int k) {
  const cv::Rect m = g.mosaic_rect(t);
  return {m.x / 2, k * (g.mosaic.height / 2) + m.y / 2, m.width / 2, m.height / 2};
}
}  // namespace

cv::Rect TileGrid::mosaic_rect(int t) const {
  const cv::Size s = tile_size();
  return {(t % cols) * s.width, (t / cols) * s.height, s.width, s.height};
}

std::vector<int> TileGrid::covering(cv::Rect box) const {
  std::vector<int> out;
  box &= cv::Rect({0, 0}, mosaic);
  if (box.empty()) return out;
  const cv::Size s = tile_size();
  for (int r = box.y / s.height; r <= (box.br().y - 1) / s.height; ++r)
    for (int c = box.x / s.width; c <= (box.br().x - 1) / s.width; ++c) out.push_back(r * cols + c);
  return out;
}

std::string TileGrid::tag() const { return fmt::format("{}x{}", cols, rows); }

TileGrid tile_grid(cv::Size mosaic, int cols, int rows) {
  return {divisions(mosaic.width, cols), divisions(mosaic.height, rows), mosaic};
}

Result<TileGrid> parse_tile_grid(std::string_view tag, cv::Size mosaic) {
  const auto x = tag.find('x');
  int cols = 0, rows = 0;
  const auto bad = [&] {
    return Error{fmt::format("tile grid '{}' does not cut a {}x{} mosaic into whole, even tiles", tag, mosaic.width,
                             mosaic.height)};
  };
  if (x == std::string_view::npos) return bad();
  const auto c = std::from_chars(tag.data(), tag.data() + x, cols);
  const auto r = std::from_chars(tag.data() + x + 1, tag.data() + tag.size(), rows);
  if (c.ec != std::errc() || c.ptr != tag.data() + x || r.ec != std::errc() || r.ptr != tag.data() + tag.size())
    return bad();
  if (cols < 1 || rows < 1 || cols > 64 || rows > 64 || mosaic.width % cols || mosaic.height % rows ||
      (mosaic.width / cols) % 2 || (mosaic.height / rows) % 2)
    return bad();
  return TileGrid{cols, rows, mosaic};
}

void copy_tile_from_planes(const cv::Mat& planes, const TileGrid& g, int t, cv::Mat& tile) {
  const cv::Size s = g.tile_size();
  const cv::Size picture(s.width / 2, s.height * 2);
  if (tile.size() != picture || tile.type() != planes.type()) tile.create(picture, planes.type());
  for (int k = 0; k < 4; ++k) {
    cv::Mat dst = tile.rowRange(k * s.height / 2, (k + 1) * s.height / 2);
    planes(plane_rect(g, t, k)).copyTo(dst);
  }
}

void copy_tile_to_planes(const cv::Mat& tile, const TileGrid& g, int t, cv::Mat& planes) {
  const cv::Size whole(g.mosaic.width / 2, g.mosaic.height * 2);
  if (planes.size() != whole || planes.type() != tile.type()) planes.create(whole, tile.type());
  const int h = g.tile_size().height / 2;
  for (int k = 0; k < 4 && (k + 1) * h <= tile.rows; ++k) {
    cv::Mat dst = planes(plane_rect(g, t, k));
    tile.rowRange(k * h, (k + 1) * h).copyTo(dst);
  }
}

}  // namespace pvcap
