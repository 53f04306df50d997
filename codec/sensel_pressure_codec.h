#pragma once
// The Sensel Morph's compressed force and label images (protocol spec §6):
// varints, the pressure stream's zero-run/value modes, the label stream's
// null/non-null runs, on the coarse grid announced by register 0x1C.
// Decoders check every count against the grid and never read past the input;
// encoders produce the device's byte form (the emulator uses them, and the
// real captures prove decode(encode(x)) == x byte for byte).
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "core/result.h"

namespace pvcap::sensel {

struct Grid {
  int cols = 0, rows = 0;      // native (coarse) grid the device sends
  int xscale = 0, yscale = 0;  // upsampling factors to the 185 x 105 sensel grid
  int cells() const { return cols * rows; }
  int out_cols() const { return (cols - 1) * xscale + 1; }
  int out_rows() const { return (rows - 1) * yscale + 1; }
  bool operator==(const Grid&) const = default;
};
// A grid a Morph can have (its grids are at most 185 x 105, scaled up at most 4 times): one read
// from a damaged store or file is refused before anything is sized by it.
inline bool plausible_grid(const Grid& g) {
  return g.cols > 0 && g.rows > 0 && g.cols <= 1024 && g.rows <= 1024 && g.xscale > 0 && g.yscale > 0 &&
         g.xscale <= 16 && g.yscale <= 16;
}
inline constexpr Grid kHighDetail{93, 53, 2, 2};
inline constexpr Grid kMediumDetail{47, 27, 4, 4};

// Register 0x1C's 6 bytes: [0..1] unknown (0), cols, rows, xscale, yscale.
Result<Grid> grid_from_metadata(std::span<const std::uint8_t> metadata);

// Reads one varint at `pos` (advancing it); Error when the input ends inside it.
Result<std::uint16_t> read_varint(std::span<const std::uint8_t> in, std::size_t& pos);
void write_varint(std::vector<std::uint8_t>& out, std::uint16_t value);  // value <= 32767

struct PressureImage {
  std::uint16_t base = 0;             // the frame's base count (3 in every captured frame)
  std::vector<std::uint16_t> counts;  // raw counts per grid cell, row-major; 0 = nothing
};
// Decodes the pressure stream starting at `pos`; on success `pos` is just past it.
Result<PressureImage> decode_pressure(std::span<const std::uint8_t> in, std::size_t& pos, const Grid& grid);
// Counts <= base cannot be sent and come out as 0 (as on the device).
std::vector<std::uint8_t> encode_pressure(const PressureImage& image);

inline constexpr std::uint8_t kNoLabel = 255;
Result<std::vector<std::uint8_t>> decode_labels(std::span<const std::uint8_t> in, std::size_t& pos, const Grid& grid);
std::vector<std::uint8_t> encode_labels(const std::vector<std::uint8_t>& labels);

}  // namespace pvcap::sensel
