#pragma once
// The picture files pvcap writes: JPEG (export, report, the operator's page) and PNG (the pressure
// image of the pages, the calibration board, a replay snapshot), straight through libjpeg-turbo and
// libpng. Not OpenCV's imgcodecs: Debian builds it with GDAL, and loading it and the 115 libraries
// it pulls in cost every pvcap process 0.15-0.25 s before main (docs/performance-log.md), on a command
// run for each of a dataset's sessions and twice per recording (the recorder and its simulator).
// The JPEG is libjpeg's baseline with 4:2:0 chroma at the given quality, as imencode writes it.
#include <cstdint>
#include <filesystem>
#include <vector>

#include <opencv2/core.hpp>

#include "core/result.h"

namespace pvcap {

// `image`: 8-bit, 1 channel (grey) or 3 (BGR); PNG also takes 4 (BGRA). Any row stride.
Result<std::vector<std::uint8_t>> encode_jpeg(const cv::Mat& image, int quality);
// The same JPEG into `buffer`, which is grown when too small and otherwise reused: a caller that
// encodes thousands (the export) allocates and faults in no fresh memory per picture. Returns the
// JPEG's length (the buffer's first bytes).
Result<std::size_t> encode_jpeg_into(const cv::Mat& image, int quality, std::vector<std::uint8_t>& buffer);
Result<std::vector<std::uint8_t>> encode_png(const cv::Mat& image);

// Writes `image` as `file`'s extension says (.png, .jpg or .jpeg; JPEG at quality 95).
Status write_image(const std::filesystem::path& file, const cv::Mat& image);

}  // namespace pvcap
