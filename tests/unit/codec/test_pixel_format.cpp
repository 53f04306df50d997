#include <gtest/gtest.h>


#include "codec/pixel_format.h"
#include "sim/scene.h"

namespace {
// A flat colour patch through a mosaic of `name` and back must keep its colour:
// this pins down OpenCV's Bayer naming against PFNC's.
void expect_colour_survives(const char* name, std::uint32_t pfnc) {
  const cv::Vec3b colour(30, 90, 200);  // B, G, R: a skin-like orange
  const cv::Mat bgr(64, 64, CV_8UC3, cv::Scalar(colour[0], colour[1], colour[2]));
  const cv::Mat raw = pvcap::sim::to_sensor_format(bgr, name);
  cv::Mat back;
  ASSERT_TRUE(pvcap::to_bgr(raw.data, raw.total() * raw.elemSize(), 64, 64, pfnc, back).ok()) << name;
  const cv::Vec3b centre = back.at<cv::Vec3b>(32, 32);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(centre[c], colour[c], 2) << name << " channel " << c;
}
}  // namespace

TEST(PixelFormat, EveryBayerLayoutKeepsColours) {
  expect_colour_survives("BayerRG8", pvcap::pfnc::kBayerRG8);
  expect_colour_survives("BayerBG8", pvcap::pfnc::kBayerBG8);
  expect_colour_survives("BayerGR8", pvcap::pfnc::kBayerGR8);
  expect_colour_survives("BayerGB8", pvcap::pfnc::kBayerGB8);
  expect_colour_survives("RGB8", pvcap::pfnc::kRGB8);
}

TEST(PixelFormat, ShortBufferIsAnErrorNotARead) {
  std::vector<std::uint8_t> small(100);
  cv::Mat out;
  const auto s = pvcap::to_bgr(small.data(), small.size(), 64, 64, pvcap::pfnc::kBayerRG8, out);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("needs 4096"), std::string::npos) << s.error().message;
}

TEST(PixelFormat, UnsupportedFormatIsNamed) {
  std::vector<std::uint8_t> buf(64 * 64 * 2);
  cv::Mat out;
  const auto s = pvcap::to_bgr(buf.data(), buf.size(), 64, 64, pvcap::pfnc::kMono16, out);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("not supported"), std::string::npos);
}
