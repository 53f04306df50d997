#pragma once
// Camera pixel formats (PFNC codes, as GigE Vision cameras and Aravis report them) to BGR images.
// Part of the codec-only target (pvcap_codec): the store's readers use it without opening a device.
#include <cstdint>
#include <string>

#include <opencv2/core.hpp>

#include "codec/demosaic.h"
#include "core/result.h"

namespace pvcap {

// The GenICam Pixel Format Naming Convention's codes (PFNC 2.x; Aravis' ARV_PIXEL_FORMAT_* have the
// same values, which capture/aravis_camera.cpp checks at compile time).
namespace pfnc {
inline constexpr std::uint32_t kMono8 = 0x01080001;
inline constexpr std::uint32_t kBayerGR8 = 0x01080008;
inline constexpr std::uint32_t kBayerRG8 = 0x01080009;
inline constexpr std::uint32_t kBayerGB8 = 0x0108000A;
inline constexpr std::uint32_t kBayerBG8 = 0x0108000B;
inline constexpr std::uint32_t kBayerGR12 = 0x01100010;
inline constexpr std::uint32_t kBayerRG12 = 0x01100011;
inline constexpr std::uint32_t kBayerGB12 = 0x01100012;
inline constexpr std::uint32_t kBayerBG12 = 0x01100013;
inline constexpr std::uint32_t kRGB8 = 0x02180014;
inline constexpr std::uint32_t kMono16 = 0x01100007;  // not one pvcap stores: refused by to_bgr
}  // namespace pfnc

// Debayers / converts `data` (width x height, PFNC `pixel_format`) into `bgr` (CV_8UC3).
Status to_bgr(const std::uint8_t* data, std::size_t size, int width, int height, std::uint32_t pixel_format,
              cv::Mat& bgr);
std::string pixel_format_name(std::uint32_t pixel_format);
// True for the Bayer mosaics (BayerRG8 ... BayerGB8, and their 12-bit forms BayerRG12 ... in 16-bit words).
bool is_bayer(std::uint32_t pixel_format);
// Bits per sample of a Bayer mosaic (8 or 12); 0 for anything else.
int bayer_bit_depth(std::uint32_t pixel_format);

// Bytes of an image of `pixel_format` (PFNC: its bits per pixel are bits 16-23 of the code), packed.
std::size_t image_bytes(int width, int height, std::uint32_t pixel_format);

// PFNC code for a name this module supports (BayerRG8, ..., Mono8, RGB8); 0 when unknown.
std::uint32_t pixel_format_code(const std::string& name);

}  // namespace pvcap
