#include "capture/demosaic.h"

#include <array>
#include <map>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

namespace pvcap {

const char* to_string(Demosaic d) {
  switch (d) {
    case Demosaic::Bilinear: return "bilinear";
    case Demosaic::EdgeAware: return "edge-aware";
    case Demosaic::Vng: return "vng";
  }
  return "?";
}

Result<Demosaic> parse_demosaic(const std::string& name) {
  for (Demosaic d : {Demosaic::Bilinear, Demosaic::EdgeAware, Demosaic::Vng})
    if (name == to_string(d)) return d;
  return Error{fmt::format("demosaicing '{}' is not one of bilinear, edge-aware, vng", name)};
}

namespace {
// OpenCV names Bayer patterns by the second row's first two pixels, so a sensor whose
// top-left 2x2 is R G / G B (PFNC BayerRG) is OpenCV's BayerBG (checked by a test).
// `pattern` is PFNC's two letters (RG, BG, GR, GB); -1 when unknown.
int opencv_bayer_code(const std::string& pattern, Demosaic method) {
  static const std::map<std::string, std::array<int, 3>> codes = {
      {"RG", {cv::COLOR_BayerBG2BGR, cv::COLOR_BayerBG2BGR_EA, cv::COLOR_BayerBG2BGR_VNG}},
      {"BG", {cv::COLOR_BayerRG2BGR, cv::COLOR_BayerRG2BGR_EA, cv::COLOR_BayerRG2BGR_VNG}},
      {"GR", {cv::COLOR_BayerGB2BGR, cv::COLOR_BayerGB2BGR_EA, cv::COLOR_BayerGB2BGR_VNG}},
      {"GB", {cv::COLOR_BayerGR2BGR, cv::COLOR_BayerGR2BGR_EA, cv::COLOR_BayerGR2BGR_VNG}},
  };
  const auto it = codes.find(pattern);
  return it == codes.end() ? -1 : it->second[std::size_t(method)];
}
}  // namespace

Status debayer(const cv::Mat& mosaic, const std::string& bayer_format, Demosaic method, cv::Mat& bgr) {
  const int code = bayer_format.rfind("Bayer", 0) == 0 && bayer_format.size() >= 7
                       ? opencv_bayer_code(bayer_format.substr(5, 2), method)
                       : -1;
  if (code < 0) return Error{fmt::format("'{}' is not a Bayer pattern pvcap knows", bayer_format)};
  if (mosaic.channels() != 1 || (mosaic.depth() != CV_8U && mosaic.depth() != CV_16U))
    return Error{fmt::format("a {} mosaic has one 8- or 16-bit channel", bayer_format)};
  if (method == Demosaic::Vng && mosaic.depth() != CV_8U)
    return Error{"VNG demosaicing takes 8-bit mosaics only: use bilinear or edge-aware"};
  cv::cvtColor(mosaic, bgr, code);
  return {};
}

}  // namespace pvcap
