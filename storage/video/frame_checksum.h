#pragma once
// The checksums that tie a stored frame to the bytes its device sent (docs/store.md, Checksums).
// Each is a CRC-32 (IEEE 802.3: the CRC of zlib's crc32(), of `cksum -a crc32b`, and of FFmpeg's
// `-f framehash -hash crc32`), taken when the frame is captured, before anything encodes it:
//   - a camera frame kept in a raw video: over the picture the raw store keeps, the mosaic's four
//     planes stacked in the video's order (storage/video/bayer_planes.h), row by row, samples
//     little-endian; so a decoded frame of the video has the same CRC, and FFmpeg alone can
//     compute it;
//   - a pressure frame: over its payload as the device sent it (pressure_frames.payload).
// A colour (lossy) video cannot give its captured bytes back; its frames carry no checksum.
#include <cstddef>
#include <cstdint>

#include <opencv2/core.hpp>

#include "storage/video/bayer_planes.h"

namespace pvcap {

std::uint32_t crc32_of(const void* data, std::size_t size);

// The CRC of `mosaic` (CV_8UC1 or CV_16UC1, even size) as its planes stacked in `order`, without
// stacking them.
std::uint32_t stored_mosaic_crc(const cv::Mat& mosaic, const PlaneOrder& order = kCellOrder);

// The CRC of a picture's rows in order (a stored picture as decoded: the planes stacked).
std::uint32_t picture_crc(const cv::Mat& picture);

}  // namespace pvcap
