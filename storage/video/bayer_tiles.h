#pragma once
// The raw store's tiles: a mosaic cut into a grid of equal tiles, each kept as its own video stream
// of the file (its four Bayer planes stacked, as storage/video/bayer_planes.h stacks a whole
// mosaic's), so that a region decodes without the rest of the frame: a training crop of a tenth of
// a 1080p image decodes the few tiles under it, not the whole picture (HuffYUV has no slices to
// skip to; docs/store.md, "Tiles").
//
// The stored picture stays the whole mosaic's planes stacked, whatever the tiling: a frame whose
// tiles are all decoded is put back together before anything checks it, so the capture checksum
// (storage/video/frame_checksum.h) is the same for a tiled and an untiled video of one frame.
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>

#include "core/result.h"

namespace pvcap {

struct TileGrid {
  int cols = 1, rows = 1;    // tiles across and down
  cv::Size mosaic;           // the whole mosaic's size
  int count() const { return cols * rows; }
  bool tiled() const { return count() > 1; }
  cv::Size tile_size() const { return {mosaic.width / cols, mosaic.height / rows}; }
  // Tile `t` (row-major: t = row * cols + col) in the mosaic's pixels.
  cv::Rect mosaic_rect(int t) const;
  // The tiles `box` (mosaic pixels) touches, in row-major order.
  std::vector<int> covering(cv::Rect box) const;
  // As the file's PVCAP_TILES tag spells it: "8x6" (columns x rows).
  std::string tag() const;
};

// The grid for a mosaic of `mosaic` size as close as the mosaic allows to `cols` x `rows` tiles:
// fewer where the size does not divide into even-sized tiles (each tile must hold whole 2x2 cells),
// down to 1 x 1 (no tiling).
TileGrid tile_grid(cv::Size mosaic, int cols, int rows);
// A file's tag back to its grid; an Error for a tag that does not describe whole, even tiles of
// `mosaic`.
Result<TileGrid> parse_tile_grid(std::string_view tag, cv::Size mosaic);

// Tile `t`'s picture (its four planes stacked, bayer_planes_size of its tile) from the whole
// mosaic's stacked planes, and back. `tile` may view a codec's buffer: it is written in place when
// its size and type fit.
void copy_tile_from_planes(const cv::Mat& planes, const TileGrid& grid, int t, cv::Mat& tile);
void copy_tile_to_planes(const cv::Mat& tile, const TileGrid& grid, int t, cv::Mat& planes);

}  // namespace pvcap
