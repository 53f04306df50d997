#include "capture/demosaic.h"

#include <array>
#include <map>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

namespace pvcap {

const char* to_string(Demosaic d) {
  switch (d) {
    case Demosaic::Bilinear:
      return "bilinear";
    case Demosaic::EdgeAware:
      return "edge-aware";
    case Demosaic::Vng:
      return "vng";
    case Demosaic::HalfSize:
      return "half-size";
  }
  return "?";
}

Result<Demosaic> parse_demosaic(const std::string& name) {
  for (Demosaic d : {Demosaic::Bilinear, Demosaic::EdgeAware, Demosaic::Vng, Demosaic::HalfSize})
    if (name == to_string(d)) return d;
  return Error{fmt::format("demosaicing '{}' is not one of bilinear, edge-aware, vng, half-size", name)};
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

Status half_size_from_planes(const cv::Mat planes[4], const std::string& bayer_format, cv::Mat& bgr) {
  // Where R and B sit in the 2x2 cell (the G are the other two), by PFNC's pattern name.
  const std::string pattern =
      bayer_format.rfind("Bayer", 0) == 0 && bayer_format.size() >= 7 ? bayer_format.substr(5, 2) : "";
  int r = -1, b = -1;
  if (pattern == "RG")
    r = 0, b = 3;
  else if (pattern == "BG")
    r = 3, b = 0;
  else if (pattern == "GR")
    r = 1, b = 2;
  else if (pattern == "GB")
    r = 2, b = 1;
  else
    return Error{fmt::format("'{}' is not a Bayer pattern pvcap knows", bayer_format)};
  int g[2], n = 0;
  for (int k = 0; k < 4; ++k)
    if (k != r && k != b) g[n++] = k;
  if (planes[r].empty() || planes[b].empty() || (planes[g[0]].empty() && planes[g[1]].empty()))
    return Error{"a half-size image needs the red, the blue and a green plane"};
  cv::Mat green;
  if (planes[g[0]].empty() || planes[g[1]].empty())  // one green only (a reader that skipped the other)
    green = planes[g[0]].empty() ? planes[g[1]] : planes[g[0]];
  else
    cv::addWeighted(planes[g[0]], 0.5, planes[g[1]], 0.5, 0, green);
  const cv::Mat bgr_planes[3] = {planes[b], green, planes[r]};
  cv::merge(bgr_planes, 3, bgr);
  return {};
}

Status debayer(const cv::Mat& mosaic, const std::string& bayer_format, Demosaic method, cv::Mat& bgr) {
  if (method == Demosaic::HalfSize) {
    if (mosaic.channels() != 1 || mosaic.cols % 2 || mosaic.rows % 2)
      return Error{fmt::format("a {} mosaic has one channel and an even size", bayer_format)};
    cv::Mat planes[4], top[2], bottom[2];
    const int pair = CV_MAKETYPE(mosaic.depth(), 2);
    cv::split(cv::Mat(mosaic.rows / 2, mosaic.cols / 2, pair, const_cast<uchar*>(mosaic.ptr(0)), mosaic.step[0] * 2),
              top);
    cv::split(cv::Mat(mosaic.rows / 2, mosaic.cols / 2, pair, const_cast<uchar*>(mosaic.ptr(1)), mosaic.step[0] * 2),
              bottom);
    planes[0] = top[0], planes[1] = top[1], planes[2] = bottom[0], planes[3] = bottom[1];
    return half_size_from_planes(planes, bayer_format, bgr);
  }
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
