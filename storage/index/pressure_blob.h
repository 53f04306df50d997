#pragma once
// Pressure counts as stored in pressure_frames.counts: the raw counts of one frame on the
// device's native grid, row-major, uint16 little-endian, compressed with zlib (RFC 1950).
// Any language reads them back with zlib alone (Python: zlib.decompress + numpy.frombuffer).
#include <cstdint>
#include <span>
#include <vector>

#include "core/result.h"

namespace pvcap {

std::vector<std::uint8_t> compress_counts(std::span<const std::uint16_t> counts);
// Errors (never throws) when the blob is not zlib data or does not hold exactly `cells` counts.
Result<std::vector<std::uint16_t>> decompress_counts(std::span<const std::uint8_t> blob, std::size_t cells);

}  // namespace pvcap
