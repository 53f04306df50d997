#include "storage/video/bayer_planes.h"

#include <vector>

#include <fmt/format.h>

#include "codec/demosaic.h"

namespace pvcap {

namespace {
// Row `parity` of every 2x2 cell of `m` seen as pairs of samples: (W/2) x (H/2), two channels.
cv::Mat cell_rows(const cv::Mat& m, int parity) {
  const int pair_type = CV_MAKETYPE(m.depth(), 2);
  return cv::Mat(m.rows / 2, m.cols / 2, pair_type, const_cast<uchar*>(m.ptr(parity)), m.step[0] * 2);
}

// Where cell `cell` sits in the stack.
int position_of(const PlaneOrder& order, int cell) {
  for (int k = 0; k < 4; ++k)
    if (order[std::size_t(k)] == cell) return k;
  CV_Error(cv::Error::StsBadArg, "a plane order names each cell once");
  return -1;
}
}  // namespace

bool is_bayer_planes_layout(std::string_view layout) {
  return layout == kBayerPlanesLayout || layout == kBayerPlanesGreenLastLayout;
}

Result<PlaneOrder> plane_order(std::string_view layout, std::string_view bayer_format) {
  if (layout == kBayerPlanesLayout) return kCellOrder;
  if (layout != kBayerPlanesGreenLastLayout)
    return Error{fmt::format("picture layout '{}' is not one this pvcap reads (update pvcap)", layout)};
  const std::string_view pattern = bayer_pattern(bayer_format);
  // RG/BG: the second row is G then B (or R), so its green comes first and is moved last.
  if (pattern == "RG" || pattern == "BG") return PlaneOrder{0, 1, 3, 2};
  if (pattern == "GR" || pattern == "GB") return kCellOrder;  // its second row ends in green already
  return Error{fmt::format("'{}' is not a Bayer pattern pvcap knows", bayer_format)};
}

void pack_bayer_planes(const cv::Mat& mosaic, cv::Mat& planes, const PlaneOrder& order) {
  CV_Assert(mosaic.channels() == 1 && mosaic.cols % 2 == 0 && mosaic.rows % 2 == 0);
  planes.create(bayer_planes_size(mosaic.size()), mosaic.type());
  const int h = mosaic.rows / 2;
  for (int parity = 0; parity < 2; ++parity) {
    // cv::split writes into views that already have its output's size and type: no copy after.
    const int first = position_of(order, 2 * parity), second = position_of(order, 2 * parity + 1);
    std::vector<cv::Mat> out{planes.rowRange(first * h, (first + 1) * h),
                             planes.rowRange(second * h, (second + 1) * h)};
    cv::split(cell_rows(mosaic, parity), out);
  }
}

void unpack_bayer_planes(const cv::Mat& planes, cv::Mat& mosaic, const PlaneOrder& order) {
  CV_Assert(planes.channels() == 1 && planes.rows % 4 == 0);
  mosaic.create(planes.rows / 2, planes.cols * 2, planes.type());
  const int h = planes.rows / 4;
  for (int parity = 0; parity < 2; ++parity) {
    const int first = position_of(order, 2 * parity), second = position_of(order, 2 * parity + 1);
    const std::vector<cv::Mat> in{planes.rowRange(first * h, (first + 1) * h),
                                  planes.rowRange(second * h, (second + 1) * h)};
    cv::Mat rows = cell_rows(mosaic, parity);
    cv::merge(in, rows);
  }
}

}  // namespace pvcap

namespace pvcap {

void add_left_residual_counts(const cv::Mat& picture, std::vector<std::uint64_t>& counts) {
  CV_Assert(picture.type() == CV_8UC1);
  counts.resize(256);
  for (int y = 0; y < picture.rows; ++y) {
    const std::uint8_t* row = picture.ptr<std::uint8_t>(y);
    std::uint8_t left = 0;
    for (int x = 0; x < picture.cols; ++x) {
      ++counts[std::uint8_t(row[x] - left)];
      left = row[x];
    }
  }
}

}  // namespace pvcap
