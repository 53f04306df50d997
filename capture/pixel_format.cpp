#include "capture/pixel_format.h"

#include <arv.h>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

namespace pvcap {

std::string pixel_format_name(std::uint32_t pf) {
  switch (pf) {
    case ARV_PIXEL_FORMAT_BAYER_RG_8: return "BayerRG8";
    case ARV_PIXEL_FORMAT_BAYER_BG_8: return "BayerBG8";
    case ARV_PIXEL_FORMAT_BAYER_GR_8: return "BayerGR8";
    case ARV_PIXEL_FORMAT_BAYER_GB_8: return "BayerGB8";
    case ARV_PIXEL_FORMAT_BAYER_RG_12: return "BayerRG12";
    case ARV_PIXEL_FORMAT_BAYER_BG_12: return "BayerBG12";
    case ARV_PIXEL_FORMAT_BAYER_GR_12: return "BayerGR12";
    case ARV_PIXEL_FORMAT_BAYER_GB_12: return "BayerGB12";
    case ARV_PIXEL_FORMAT_MONO_8: return "Mono8";
    case ARV_PIXEL_FORMAT_RGB_8_PACKED: return "RGB8";
    default: return fmt::format("0x{:08x}", pf);
  }
}

std::uint32_t pixel_format_code(const std::string& name) {
  for (std::uint32_t pf : {ARV_PIXEL_FORMAT_BAYER_RG_8, ARV_PIXEL_FORMAT_BAYER_BG_8, ARV_PIXEL_FORMAT_BAYER_GR_8,
                           ARV_PIXEL_FORMAT_BAYER_GB_8, ARV_PIXEL_FORMAT_BAYER_RG_12, ARV_PIXEL_FORMAT_BAYER_BG_12,
                           ARV_PIXEL_FORMAT_BAYER_GR_12, ARV_PIXEL_FORMAT_BAYER_GB_12, ARV_PIXEL_FORMAT_MONO_8,
                           ARV_PIXEL_FORMAT_RGB_8_PACKED})
    if (pixel_format_name(pf) == name) return pf;
  return 0;
}

bool is_bayer(std::uint32_t pf) { return bayer_bit_depth(pf) > 0; }

int bayer_bit_depth(std::uint32_t pf) {
  switch (pf) {
    case ARV_PIXEL_FORMAT_BAYER_RG_8:
    case ARV_PIXEL_FORMAT_BAYER_BG_8:
    case ARV_PIXEL_FORMAT_BAYER_GR_8:
    case ARV_PIXEL_FORMAT_BAYER_GB_8: return 8;
    case ARV_PIXEL_FORMAT_BAYER_RG_12:
    case ARV_PIXEL_FORMAT_BAYER_BG_12:
    case ARV_PIXEL_FORMAT_BAYER_GR_12:
    case ARV_PIXEL_FORMAT_BAYER_GB_12: return 12;
    default: return 0;
  }
}

Status to_bgr(const std::uint8_t* data, std::size_t size, int width, int height, std::uint32_t pf, cv::Mat& bgr) {
  const bool rgb = pf == ARV_PIXEL_FORMAT_RGB_8_PACKED;
  const bool wide = bayer_bit_depth(pf) > 8;  // 10/12-bit samples in 16-bit little-endian words
  const std::size_t need = std::size_t(width) * std::size_t(height) * (rgb ? 3 : wide ? 2 : 1);
  if (!data || size < need)
    return Error{fmt::format("frame has {} bytes, {}x{} {} needs {}", size, width, height, pixel_format_name(pf), need)};
  const cv::Mat in(height, width, rgb ? CV_8UC3 : wide ? CV_16UC1 : CV_8UC1, const_cast<std::uint8_t*>(data));
  if (wide) {  // colour images are 8-bit: the top 8 of the sensor's bits
    cv::Mat bgr16;
    if (Status s = debayer(in, pixel_format_name(pf), Demosaic::Bilinear, bgr16); !s.ok()) return s;
    bgr16.convertTo(bgr, CV_8U, 1.0 / double(1 << (bayer_bit_depth(pf) - 8)));
    return {};
  }
  if (is_bayer(pf)) return debayer(in, pixel_format_name(pf), Demosaic::Bilinear, bgr);
  if (pf == ARV_PIXEL_FORMAT_MONO_8) cv::cvtColor(in, bgr, cv::COLOR_GRAY2BGR);
  else if (rgb) cv::cvtColor(in, bgr, cv::COLOR_RGB2BGR);
  else return Error{fmt::format("pixel format {} is not supported", pixel_format_name(pf))};
  return {};
}

}  // namespace pvcap
