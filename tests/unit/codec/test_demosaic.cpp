// Half-size images straight at a viewer's size: the two-thirds kernel against its definition and
// against OpenCV's bilinear resize, on sizes that use its vector blocks and its scalar tails.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "codec/demosaic.h"

using namespace pvcap;

namespace {
cv::Mat random_plane(cv::Size size, std::uint64_t seed) {
  cv::Mat m(size, CV_8UC1);
  cv::RNG(seed).fill(m, cv::RNG::UNIFORM, 0, 256);
  return m;
}

// The definition, one pixel at a time: output (x, y) lies at source (1.5 x + 0.25, 1.5 y + 0.25),
// between its four nearest source pixels, weighted 3:1 each way.
cv::Mat two_thirds_by_hand(const cv::Mat planes[3]) {
  const cv::Size in = planes[0].size();
  cv::Mat out(in.height / 3 * 2, in.width / 3 * 2, CV_8UC3);
  for (int y = 0; y < out.rows; ++y)
    for (int x = 0; x < out.cols; ++x) {
      const int sy = y / 2 * 3 + (y % 2), sx = x / 2 * 3 + (x % 2);  // the top-left of the four
      const int wy0 = y % 2 ? 1 : 3, wx0 = x % 2 ? 1 : 3;            // the weight of the first row, column
      for (int c = 0; c < 3; ++c) {
        const cv::Mat& p = planes[c];
        const int v = wy0 * (wx0 * p.at<uchar>(sy, sx) + (4 - wx0) * p.at<uchar>(sy, sx + 1)) +
                      (4 - wy0) * (wx0 * p.at<uchar>(sy + 1, sx) + (4 - wx0) * p.at<uchar>(sy + 1, sx + 1));
        out.at<cv::Vec3b>(y, x)[c] = uchar((v + 8) >> 4);
      }
    }
  return out;
}
}  // namespace

TEST(Demosaic, TwoThirdsIsBilinearAtTheSamePlacesAsOpenCv) {
  // 960 x 540 is a 1080p mosaic's half size; 99 x 63 leaves a scalar tail across and down.
  for (const cv::Size size : {cv::Size(960, 540), cv::Size(99, 63), cv::Size(48, 3)}) {
    const cv::Mat planes[3] = {random_plane(size, 1), random_plane(size, 2), random_plane(size, 3)};
    cv::Mat got;
    two_thirds_bgr(planes, got);
    ASSERT_EQ(got.size(), cv::Size(size.width * 2 / 3, size.height * 2 / 3));
    ASSERT_EQ(got.type(), CV_8UC3);
    EXPECT_EQ(cv::norm(got, two_thirds_by_hand(planes), cv::NORM_INF), 0.0) << size;
    cv::Mat merged, resized;
    cv::merge(planes, 3, merged);
    cv::resize(merged, resized, got.size(), 0, 0, cv::INTER_LINEAR);
    EXPECT_LE(cv::norm(got, resized, cv::NORM_INF), 1.0) << size;
  }
}

TEST(Demosaic, AHalfSizeImageAtAnySizeIsTheHalfSizeImageScaled) {
  // BayerGB: G B / R G. Both greens present: their mean; one absent: the other alone.
  const cv::Size half(96, 54);
  cv::Mat planes[4];
  for (int k = 0; k < 4; ++k) planes[k] = random_plane(half, 10 + std::uint64_t(k));
  cv::Mat whole;
  ASSERT_TRUE(half_size_from_planes(planes, "BayerGB8", whole).ok());
  for (const cv::Size size : {cv::Size(64, 36), cv::Size(50, 30), half}) {
    cv::Mat scaled;
    ASSERT_TRUE(scaled_half_size_from_planes(planes, "BayerGB8", size, scaled).ok());
    ASSERT_EQ(scaled.size(), size);
    cv::Mat want;
    cv::resize(whole, want, size, 0, 0, cv::INTER_LINEAR);
    EXPECT_LE(cv::norm(scaled, want, cv::NORM_INF), size == cv::Size(64, 36) ? 1.0 : 0.0) << size;
  }
  planes[3] = cv::Mat();  // a three-plane reader's
  cv::Mat scaled;
  ASSERT_TRUE(scaled_half_size_from_planes(planes, "BayerGB8", {64, 36}, scaled).ok());
  const cv::Mat bgr[3] = {planes[1], planes[0], planes[2]};
  EXPECT_EQ(cv::norm(scaled, two_thirds_by_hand(bgr), cv::NORM_INF), 0.0);
  EXPECT_FALSE(scaled_half_size_from_planes(planes, "Mono8", {64, 36}, scaled).ok());
}
