#include "codec/pixel_format.h"

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

namespace pvcap {

using namespace pfnc;

std::size_t image_bytes(int width, int height, std::uint32_t pixel_format) {
  if (width <= 0 || height <= 0) return 0;
  return std::size_t(width) * std::size_t(height) * ((pixel_format >> 16) & 0xff) / 8;
}

std::string pixel_format_name(std::uint32_t pf) {
  switch (pf) {
    case kBayerRG8:
      return "BayerRG8";
    case kBayerBG8:
      return "BayerBG8";
    case kBayerGR8:
      return "BayerGR8";
    case kBayerGB8:
      return "BayerGB8";
    case kBayerRG12:
      return "BayerRG12";
    case kBayerBG12:
      return "BayerBG12";
    case kBayerGR12:
      return "BayerGR12";
    case kBayerGB12:
      return "BayerGB12";
    case kMono8:
      return "Mono8";
    case kRGB8:
      return "RGB8";
    default:
      return fmt::format("0x{:08x}", pf);
  }
}

std::uint32_t pixel_format_code(const std::string& name) {
  for (std::uint32_t pf :
       {kBayerRG8, kBayerBG8, kBayerGR8, kBayerGB8, kBayerRG12, kBayerBG12, kBayerGR12, kBayerGB12, kMono8, kRGB8})
    if (pixel_format_name(pf) == name) return pf;
  return 0;
}

bool is_bayer(std::uint32_t pf) { return bayer_bit_depth(pf) > 0; }

int bayer_bit_depth(std::uint32_t pf) {
  switch (pf) {
    case kBayerRG8:
    case kBayerBG8:
    case kBayerGR8:
    case kBayerGB8:
      return 8;
    case kBayerRG12:
    case kBayerBG12:
    case kBayerGR12:
    case kBayerGB12:
      return 12;
    default:
      return 0;
  }
}

Status to_bgr(const std::uint8_t* data, std::size_t size, int width, int height, std::uint32_t pf, cv::Mat& bgr) {
  const bool rgb = pf == kRGB8;
  const bool wide = bayer_bit_depth(pf) > 8;  // 10/12-bit samples in 16-bit little-endian words
  const std::size_t need = std::size_t(width) * std::size_t(height) * (rgb ? 3 : wide ? 2 : 1);
  if (!data || size < need)
    return Error{
        fmt::format("frame has {} bytes, {}x{} {} needs {}", size, width, height, pixel_format_name(pf), need)};
  const cv::Mat in(height, width, rgb ? CV_8UC3 : wide ? CV_16UC1 : CV_8UC1, const_cast<std::uint8_t*>(data));
  if (wide) {  // colour images are 8-bit: the top 8 of the sensor's bits
    cv::Mat bgr16;
    if (Status s = debayer(in, pixel_format_name(pf), Demosaic::Bilinear, bgr16); !s.ok()) return s;
    bgr16.convertTo(bgr, CV_8U, 1.0 / double(1 << (bayer_bit_depth(pf) - 8)));
    return {};
  }
  if (is_bayer(pf)) return debayer(in, pixel_format_name(pf), Demosaic::Bilinear, bgr);
  if (pf == kMono8)
    cv::cvtColor(in, bgr, cv::COLOR_GRAY2BGR);
  else if (rgb)
    cv::cvtColor(in, bgr, cv::COLOR_RGB2BGR);
  else
    return Error{fmt::format("pixel format {} is not supported", pixel_format_name(pf))};
  return {};
}

}  // namespace pvcap
