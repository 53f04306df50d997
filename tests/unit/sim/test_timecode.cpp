#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "codec/pixel_format.h"
#include "sim/scene.h"
#include "sim/timecode.h"

#include <arv.h>

using namespace pvcap::sim;

TEST(Timecode, RoundTripsThroughAMosaicAndDebayering) {
  const cv::Size size(640, 360);
  const cv::Mat bgr = render_default_scene_bgr(0, size);
  cv::Mat mosaic = to_sensor_format(bgr, "BayerRG8");
  const Timecode tc{1234567890123456789LL, 65535};
  draw_timecode(mosaic, tc);
  cv::Mat back;
  ASSERT_TRUE(
      pvcap::to_bgr(mosaic.data, mosaic.total(), size.width, size.height, ARV_PIXEL_FORMAT_BAYER_RG_8, back).ok());
  const auto got = read_timecode(back);
  ASSERT_TRUE(got.has_value());
  EXPECT_EQ(*got, tc);
}

TEST(Timecode, SurvivesBlurAndNoise) {
  cv::Mat grey(1080, 1920, CV_8UC1, cv::Scalar(90));
  const Timecode tc{42, 7};
  draw_timecode(grey, tc);
  cv::GaussianBlur(grey, grey, cv::Size(5, 5), 1.5);
  cv::Mat noise(grey.size(), CV_8UC1);
  cv::randn(noise, 0, 10);
  grey += noise;
  EXPECT_EQ(read_timecode(grey), tc);
}

TEST(Timecode, CorruptedCellsAreRejectedNotMisread) {
  cv::Mat grey(360, 640, CV_8UC1, cv::Scalar(0));
  draw_timecode(grey, Timecode{987654321, 99});
  const int c = timecode_cell_px(640);
  cv::Mat cell = grey(cv::Rect(5 * c, c, c, c));
  cell.setTo(255 - cell.at<uchar>(c / 2, c / 2));  // flip one bit
  EXPECT_FALSE(read_timecode(grey).has_value());
}

TEST(Timecode, ImageWithoutTimecodeReadsAsNothing) {
  cv::Mat grey(360, 640, CV_8UC1, cv::Scalar(128));
  EXPECT_FALSE(read_timecode(grey).has_value());
}

TEST(FrameStripe, MatchesItsOwnFrameAndShowsAStaleBand) {
  cv::Mat a(360, 640, CV_8UC1, cv::Scalar(100)), b;
  draw_frame_stripe(a, 1000);
  EXPECT_EQ(frame_stripe_mismatches(a, 1000), 0);
  // Any other frame id disagrees in many cells (it is a different pattern).
  EXPECT_GT(frame_stripe_mismatches(a, 1001), 5);
  // A band of rows left over from frame 970 is visible.
  b = a.clone();
  cv::Mat old(360, 640, CV_8UC1, cv::Scalar(100));
  draw_frame_stripe(old, 970);
  old.rowRange(100, 200).copyTo(b.rowRange(100, 200));
  EXPECT_GT(frame_stripe_mismatches(b, 1000), 0);
}
