#include "codec/sensel_pressure_codec.h"

#include <fmt/format.h>

namespace pvcap::sensel {

Result<Grid> grid_from_metadata(std::span<const std::uint8_t> m) {
  if (m.size() != 6) return Error{fmt::format("compression metadata has {} bytes, expected 6", m.size())};
  const Grid g{m[2], m[3], m[4], m[5]};
  if (g.cols < 2 || g.rows < 2 || g.xscale < 1 || g.yscale < 1)
    return Error{fmt::format("compression metadata describes an impossible grid {}x{} scale {}x{}", g.cols, g.rows,
                             g.xscale, g.yscale)};
  return g;
}

Result<std::uint16_t> read_varint(std::span<const std::uint8_t> in, std::size_t& pos) {
  if (pos >= in.size()) return Error{"stream ends where a value was expected"};
  const std::uint8_t first = in[pos++];
  if (!(first & 0x80)) return std::uint16_t(first);
  if (pos >= in.size()) return Error{"stream ends inside a two-byte value"};
  return std::uint16_t((first & 0x7F) | (std::uint16_t(in[pos++]) << 7));
}

void write_varint(std::vector<std::uint8_t>& out, std::uint16_t v) {
  if (v < 0x80) {
    out.push_back(std::uint8_t(v));
  } else {
    out.push_back(std::uint8_t(0x80 | (v & 0x7F)));
    out.push_back(std::uint8_t(v >> 7));
  }
}

Result<PressureImage> decode_pressure(std::span<const std::uint8_t> in, std::size_t& pos, const Grid& grid) {
  if (!plausible_grid(grid))
    return Error{fmt::format("pressure: no Morph has a {}x{} grid scaled {}x{}", grid.cols, grid.rows, grid.xscale,
                             grid.yscale)};
  PressureImage img;
  const std::size_t total = std::size_t(grid.cells());
  img.counts.reserve(total);
  auto base = read_varint(in, pos);
  if (!base) return Error{"pressure: " + base.error().message};
  img.base = base.value();
  bool zero_run = true;
  while (img.counts.size() < total) {
    auto v = read_varint(in, pos);
    if (!v) return Error{fmt::format("pressure: {} after {} of {} cells", v.error().message, img.counts.size(), total)};
    if (zero_run) {
      if (img.counts.size() + v.value() > total)
        return Error{fmt::format("pressure: a run of {} empty cells overflows the {}x{} grid at cell {}", v.value(),
                                 grid.cols, grid.rows, img.counts.size())};
      img.counts.insert(img.counts.end(), v.value(), 0);
      zero_run = false;
    } else if (v.value() == 0) {
      zero_run = true;
    } else {
      const unsigned value = unsigned(img.base) + v.value();
      if (value > 0xFFFF) return Error{fmt::format("pressure: count {} out of range", value)};
      img.counts.push_back(std::uint16_t(value));
    }
  }
  return img;
}

std::vector<std::uint8_t> encode_pressure(const PressureImage& img) {
  std::vector<std::uint8_t> out;
  write_varint(out, img.base);
  const std::size_t total = img.counts.size();
  auto sendable = [&](std::size_t i) { return img.counts[i] > img.base; };
  std::size_t i = 0;
  while (i < total) {
    std::size_t n = 0;  // zero-run mode: how many empty cells (0 is allowed)
    while (i + n < total && !sendable(i + n)) ++n;
    write_varint(out, std::uint16_t(n));
    i += n;
    if (i == total) break;
    while (i < total && sendable(i)) write_varint(out, std::uint16_t(img.counts[i++] - img.base));
    if (i == total) break;
    write_varint(out, 0);  // back to zero-run mode
  }
  return out;
}

Result<std::vector<std::uint8_t>> decode_labels(std::span<const std::uint8_t> in, std::size_t& pos, const Grid& grid) {
  const std::size_t total = std::size_t(grid.cells());
  std::vector<std::uint8_t> labels;
  labels.reserve(total);
  bool null_mode = true;
  while (labels.size() < total) {
    auto run = read_varint(in, pos);
    if (!run) return Error{fmt::format("labels: {} after {} of {} cells", run.error().message, labels.size(), total)};
    if (labels.size() + run.value() > total)
      return Error{fmt::format("labels: a run of {} overflows the {}x{} grid at cell {}", run.value(), grid.cols,
                               grid.rows, labels.size())};
    if (null_mode) {
      labels.insert(labels.end(), run.value(), kNoLabel);
      null_mode = false;
    } else {
      if (pos >= in.size()) return Error{"labels: stream ends where a label id was expected"};
      const std::uint8_t b = in[pos++];
      labels.insert(labels.end(), run.value(), std::uint8_t(b & 0x7F));
      null_mode = b < 0x80;
    }
  }
  return labels;
}

std::vector<std::uint8_t> encode_labels(const std::vector<std::uint8_t>& labels) {
  std::vector<std::uint8_t> out;
  const std::size_t total = labels.size();
  std::size_t i = 0;
  bool null_mode = true;
  while (i < total) {
    std::size_t r = 0;
    if (null_mode) {
      while (i + r < total && labels[i + r] == kNoLabel) ++r;
      write_varint(out, std::uint16_t(r));
      i += r;
      null_mode = false;
      continue;
    }
    const std::uint8_t id = labels[i];
    while (i + r < total && labels[i + r] == id) ++r;
    i += r;
    // Another labelled run follows directly: stay in non-null mode (bit 7).
    const bool next_labelled = i < total && labels[i] != kNoLabel;
    write_varint(out, std::uint16_t(r));
    out.push_back(std::uint8_t(id | (next_labelled ? 0x80 : 0)));
    null_mode = !next_labelled;
  }
  return out;
}

}  // namespace pvcap::sensel
