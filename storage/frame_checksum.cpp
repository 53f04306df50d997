#include "storage/frame_checksum.h"

#include <vector>

#include <zlib.h>

namespace pvcap {

namespace {
std::uint32_t extend(std::uint32_t crc, const void* data, std::size_t size) {
  // zlib takes at most 4 GB at a time (uInt); a picture row is far less.
  return std::uint32_t(crc32(uLong(crc), static_cast<const Bytef*>(data), uInt(size)));
}

template <typename Sample>
std::uint32_t planes_crc(const cv::Mat& mosaic) {
  std::uint32_t crc = 0;
  std::vector<Sample> row(std::size_t(mosaic.cols / 2));
  // The planes' order (storage/bayer_planes.h): the 2x2 cell's top-left, top-right, bottom-left,
  // bottom-right samples.
  for (int parity_y = 0; parity_y < 2; ++parity_y)
    for (int parity_x = 0; parity_x < 2; ++parity_x)
      for (int y = parity_y; y < mosaic.rows; y += 2) {
        const Sample* in = mosaic.ptr<Sample>(y) + parity_x;
        for (std::size_t x = 0; x < row.size(); ++x) row[x] = in[2 * x];
        crc = extend(crc, row.data(), row.size() * sizeof(Sample));
      }
  return crc;
}
}  // namespace

std::uint32_t crc32_of(const void* data, std::size_t size) { return extend(0, data, size); }

std::uint32_t stored_mosaic_crc(const cv::Mat& mosaic) {
  CV_Assert(mosaic.channels() == 1 && mosaic.cols % 2 == 0 && mosaic.rows % 2 == 0);
  return mosaic.depth() == CV_16U ? planes_crc<std::uint16_t>(mosaic) : planes_crc<std::uint8_t>(mosaic);
}

std::uint32_t picture_crc(const cv::Mat& picture) {
  std::uint32_t crc = 0;
  const std::size_t row_bytes = std::size_t(picture.cols) * picture.elemSize();
  for (int y = 0; y < picture.rows; ++y) crc = extend(crc, picture.ptr(y), row_bytes);
  return crc;
}

}  // namespace pvcap
