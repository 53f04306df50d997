#include "storage/index/pressure_blob.h"

#include <zlib.h>

#include <fmt/format.h>

namespace pvcap {

std::vector<std::uint8_t> compress_counts(std::span<const std::uint16_t> counts) {
  std::vector<std::uint8_t> raw(counts.size() * 2);
  for (std::size_t i = 0; i < counts.size(); ++i) {
    raw[2 * i] = std::uint8_t(counts[i] & 0xff);
    raw[2 * i + 1] = std::uint8_t(counts[i] >> 8);
  }
  uLongf size = compressBound(uLong(raw.size()));
  std::vector<std::uint8_t> out(size);
  // Level 1: pressure images are mostly zeros, so the fastest level already shrinks them ~20x.
  compress2(out.data(), &size, raw.data(), uLong(raw.size()), 1);
  out.resize(size);
  return out;
}

Result<std::vector<std::uint16_t>> decompress_counts(std::span<const std::uint8_t> blob, std::size_t cells) {
  std::vector<std::uint8_t> raw(cells * 2 + 1);  // one spare byte: a longer stream shows as a size mismatch
  uLongf size = uLongf(raw.size());
  const int rc = uncompress(raw.data(), &size, blob.data(), uLong(blob.size()));
  if (rc != Z_OK && rc != Z_BUF_ERROR)
    return Error{fmt::format("pressure counts are not zlib data ({})", rc == Z_DATA_ERROR ? "corrupt" : "error")};
  if (rc == Z_BUF_ERROR)
    return Error{fmt::format("pressure counts are cut short or exceed the grid's {} bytes", cells * 2)};
  if (size != cells * 2) return Error{fmt::format("pressure counts hold {} bytes, the grid needs {}", size, cells * 2)};
  std::vector<std::uint16_t> counts(cells);
  for (std::size_t i = 0; i < cells; ++i) counts[i] = std::uint16_t(raw[2 * i] | (raw[2 * i + 1] << 8));
  return counts;
}

}  // namespace pvcap
