#include "storage/bayer_planes.h"

#include <vector>

namespace pvcap {

namespace {
// Row `parity` of every 2x2 cell of `m` seen as pairs of samples: (W/2) x (H/2), two channels.
cv::Mat cell_rows(const cv::Mat& m, int parity) {
  const int pair_type = CV_MAKETYPE(m.depth(), 2);
  return cv::Mat(m.rows / 2, m.cols / 2, pair_type, const_cast<uchar*>(m.ptr(parity)), m.step[0] * 2);
}
}  // namespace

void pack_bayer_planes(const cv::Mat& mosaic, cv::Mat& planes) {
  CV_Assert(mosaic.channels() == 1 && mosaic.cols % 2 == 0 && mosaic.rows % 2 == 0);
  planes.create(bayer_planes_size(mosaic.size()), mosaic.type());
  const int h = mosaic.rows / 2;
  for (int parity = 0; parity < 2; ++parity) {
    // cv::split writes into views that already have its output's size and type: no copy after.
    std::vector<cv::Mat> out{planes.rowRange((2 * parity) * h, (2 * parity + 1) * h),
                             planes.rowRange((2 * parity + 1) * h, (2 * parity + 2) * h)};
    cv::split(cell_rows(mosaic, parity), out);
  }
}

void unpack_bayer_planes(const cv::Mat& planes, cv::Mat& mosaic) {
  CV_Assert(planes.channels() == 1 && planes.rows % 4 == 0);
  mosaic.create(planes.rows / 2, planes.cols * 2, planes.type());
  const int h = planes.rows / 4;
  for (int parity = 0; parity < 2; ++parity) {
    const std::vector<cv::Mat> in{planes.rowRange((2 * parity) * h, (2 * parity + 1) * h),
                                  planes.rowRange((2 * parity + 1) * h, (2 * parity + 2) * h)};
    cv::Mat rows = cell_rows(mosaic, parity);
    cv::merge(in, rows);
  }
}

}  // namespace pvcap
