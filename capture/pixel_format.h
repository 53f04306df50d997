#pragma once
// Camera pixel formats (PFNC codes as Aravis reports them) to BGR images.
#include <cstdint>
#include <string>

#include <opencv2/core.hpp>

#include "capture/demosaic.h"
#include "core/result.h"

namespace pvcap {

// Debayers / converts `data` (width x height, PFNC `pixel_format`) into `bgr` (CV_8UC3).
Status to_bgr(const std::uint8_t* data, std::size_t size, int width, int height, std::uint32_t pixel_format,
              cv::Mat& bgr);
std::string pixel_format_name(std::uint32_t pixel_format);
// True for the Bayer mosaics (BayerRG8 ... BayerGB8, and their 12-bit forms BayerRG12 ... in 16-bit words).
bool is_bayer(std::uint32_t pixel_format);
// Bits per sample of a Bayer mosaic (8 or 12); 0 for anything else.
int bayer_bit_depth(std::uint32_t pixel_format);

// PFNC code for a name this module supports (BayerRG8, ..., Mono8, RGB8); 0 when unknown.
std::uint32_t pixel_format_code(const std::string& name);

}  // namespace pvcap
