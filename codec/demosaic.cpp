#include "codec/demosaic.h"

#include <array>
#include <map>

#include <fmt/format.h>
#include <opencv2/core/hal/intrin.hpp>
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

std::string_view bayer_pattern(std::string_view bayer_format) {
  return bayer_format.substr(0, 5) == "Bayer" && bayer_format.size() >= 7 ? bayer_format.substr(5, 2) : "";
}

namespace {
// OpenCV names Bayer patterns by the second row's first two pixels, so a sensor whose
// top-left 2x2 is R G / G B (PFNC BayerRG) is OpenCV's BayerBG (checked by a test).
// `pattern` is PFNC's two letters (RG, BG, GR, GB); -1 when unknown.
int opencv_bayer_code(std::string_view pattern, Demosaic method) {
  static const std::map<std::string, std::array<int, 3>, std::less<>> codes = {
      {"RG", {cv::COLOR_BayerBG2BGR, cv::COLOR_BayerBG2BGR_EA, cv::COLOR_BayerBG2BGR_VNG}},
      {"BG", {cv::COLOR_BayerRG2BGR, cv::COLOR_BayerRG2BGR_EA, cv::COLOR_BayerRG2BGR_VNG}},
      {"GR", {cv::COLOR_BayerGB2BGR, cv::COLOR_BayerGB2BGR_EA, cv::COLOR_BayerGB2BGR_VNG}},
      {"GB", {cv::COLOR_BayerGR2BGR, cv::COLOR_BayerGR2BGR_EA, cv::COLOR_BayerGR2BGR_VNG}},
  };
  const auto it = codes.find(pattern);
  return it == codes.end() ? -1 : it->second[std::size_t(method)];
}

// The half-size image's blue, green and red planes from the cell's four.
Status colour_planes(const cv::Mat planes[4], const std::string& bayer_format, cv::Mat bgr_planes[3]) {
  // Where R and B sit in the 2x2 cell (the G are the other two), by PFNC's pattern name.
  const std::string_view pattern = bayer_pattern(bayer_format);
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
  if (planes[g[0]].empty() || planes[g[1]].empty())  // one green only (a reader that skipped the other)
    bgr_planes[1] = planes[g[0]].empty() ? planes[g[1]] : planes[g[0]];
  else
    cv::addWeighted(planes[g[0]], 0.5, planes[g[1]], 0.5, 0, bgr_planes[1]);
  bgr_planes[0] = planes[b], bgr_planes[2] = planes[r];
  return {};
}
}  // namespace

Status half_size_from_planes(const cv::Mat planes[4], const std::string& bayer_format, cv::Mat& bgr) {
  cv::Mat bgr_planes[3];
  if (Status s = colour_planes(planes, bayer_format, bgr_planes); !s.ok()) return s;
  cv::merge(bgr_planes, 3, bgr);
  return {};
}

Status scaled_half_size_from_planes(const cv::Mat planes[4], const std::string& bayer_format, cv::Size size,
                                    cv::Mat& bgr) {
  cv::Mat bgr_planes[3];
  if (Status s = colour_planes(planes, bayer_format, bgr_planes); !s.ok()) return s;
  const cv::Size half = bgr_planes[0].size();
  if (size == half) {
    cv::merge(bgr_planes, 3, bgr);
  } else if (bgr_planes[0].depth() == CV_8U && size.width * 3 == half.width * 2 && size.height * 3 == half.height * 2) {
    two_thirds_bgr(bgr_planes, bgr);
  } else {
    cv::Mat whole;
    cv::merge(bgr_planes, 3, whole);
    cv::resize(whole, bgr, size, 0, 0, cv::INTER_LINEAR);
  }
  return {};
}

namespace {
// One source row across: h[2k] = 3 s[3k] + s[3k+1], h[2k+1] = s[3k+1] + 3 s[3k+2] (at most 1020).
void two_thirds_across(const uchar* s, ushort* h, int groups) {
  int k = 0;
#if CV_SIMD128
  for (; k + 16 <= groups; k += 16) {
    cv::v_uint8x16 a, b, c;
    cv::v_load_deinterleave(s + 3 * k, a, b, c);
    cv::v_uint16x8 a0, a1, b0, b1, c0, c1;
    cv::v_expand(a, a0, a1);
    cv::v_expand(b, b0, b1);
    cv::v_expand(c, c0, c1);
    cv::v_store_interleave(h + 2 * k, (a0 << 1) + a0 + b0, b0 + (c0 << 1) + c0);
    cv::v_store_interleave(h + 2 * k + 16, (a1 << 1) + a1 + b1, b1 + (c1 << 1) + c1);
  }
#endif
  for (; k < groups; ++k) {
    h[2 * k] = ushort(3 * s[3 * k] + s[3 * k + 1]);
    h[2 * k + 1] = ushort(s[3 * k + 1] + 3 * s[3 * k + 2]);
  }
}

// Two output rows from three rows across: (3 h0 + h1 + 8) / 16 and (h1 + 3 h2 + 8) / 16.
void two_thirds_down(const ushort* h0, const ushort* h1, const ushort* h2, uchar* top, uchar* bottom, int n) {
  int x = 0;
#if CV_SIMD128
  const cv::v_uint16x8 half = cv::v_setall_u16(8);
  for (; x + 16 <= n; x += 16) {
    const cv::v_uint16x8 p0 = cv::v_load(h0 + x), p1 = cv::v_load(h0 + x + 8), q0 = cv::v_load(h1 + x),
                         q1 = cv::v_load(h1 + x + 8), r0 = cv::v_load(h2 + x), r1 = cv::v_load(h2 + x + 8);
    cv::v_store(top + x, cv::v_pack(((p0 << 1) + p0 + q0 + half) >> 4, ((p1 << 1) + p1 + q1 + half) >> 4));
    cv::v_store(bottom + x, cv::v_pack((q0 + (r0 << 1) + r0 + half) >> 4, (q1 + (r1 << 1) + r1 + half) >> 4));
  }
#endif
  for (; x < n; ++x) {
    top[x] = uchar((3 * h0[x] + h1[x] + 8) >> 4);
    bottom[x] = uchar((h1[x] + 3 * h2[x] + 8) >> 4);
  }
}

void interleave_bgr(const uchar* b, const uchar* g, const uchar* r, uchar* out, int n) {
  int x = 0;
#if CV_SIMD128
  for (; x + 16 <= n; x += 16)
    cv::v_store_interleave(out + 3 * x, cv::v_load(b + x), cv::v_load(g + x), cv::v_load(r + x));
#endif
  for (; x < n; ++x) out[3 * x] = b[x], out[3 * x + 1] = g[x], out[3 * x + 2] = r[x];
}
}  // namespace

void two_thirds_bgr(const cv::Mat planes_bgr[3], cv::Mat& bgr) {
  const cv::Size in = planes_bgr[0].size();
  for (int c = 0; c < 3; ++c) CV_Assert(planes_bgr[c].type() == CV_8UC1 && planes_bgr[c].size() == in);
  CV_Assert(in.width % 3 == 0 && in.height % 3 == 0);
  const int groups = in.width / 3, n = 2 * groups;
  bgr.create(in.height / 3 * 2, n, CV_8UC3);
  std::vector<ushort> across(std::size_t(3 * n));
  std::vector<uchar> rows(std::size_t(6 * n));  // per colour: its top row, then its bottom row
  for (int y = 0; y < in.height / 3; ++y) {
    for (int c = 0; c < 3; ++c) {
      for (int j = 0; j < 3; ++j)
        two_thirds_across(planes_bgr[c].ptr<uchar>(3 * y + j), &across[std::size_t(j * n)], groups);
      two_thirds_down(&across[0], &across[std::size_t(n)], &across[std::size_t(2 * n)], &rows[std::size_t(2 * c * n)],
                      &rows[std::size_t((2 * c + 1) * n)], n);
    }
    for (int j = 0; j < 2; ++j)
      interleave_bgr(&rows[std::size_t(j * n)], &rows[std::size_t((2 + j) * n)], &rows[std::size_t((4 + j) * n)],
                     bgr.ptr<uchar>(2 * y + j), n);
  }
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
  const int code = opencv_bayer_code(bayer_pattern(bayer_format), method);
  if (code < 0) return Error{fmt::format("'{}' is not a Bayer pattern pvcap knows", bayer_format)};
  if (mosaic.channels() != 1 || (mosaic.depth() != CV_8U && mosaic.depth() != CV_16U))
    return Error{fmt::format("a {} mosaic has one 8- or 16-bit channel", bayer_format)};
  if (method == Demosaic::Vng && mosaic.depth() != CV_8U)
    return Error{"VNG demosaicing takes 8-bit mosaics only: use bilinear or edge-aware"};
  cv::cvtColor(mosaic, bgr, code);
  return {};
}

}  // namespace pvcap
