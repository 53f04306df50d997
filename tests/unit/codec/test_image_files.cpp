#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "codec/image_files.h"
#include "sim/scene.h"

using namespace pvcap;
namespace fs = std::filesystem;

namespace {
cv::Mat scene_bgr() { return sim::render_default_scene_bgr(2, {320, 180}); }

bool same(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::countNonZero(a.reshape(1) != b.reshape(1)) == 0;
}
}  // namespace

// What pvcap wrote through OpenCV's imencode before (export's JPEGs above all), byte for byte: the
// same libjpeg-turbo with the same settings, so an export's files and hashes do not change.
TEST(ImageFiles, AJpegIsTheSameBytesAsOpenCvsImencode) {
  cv::Mat grey;
  cv::cvtColor(scene_bgr(), grey, cv::COLOR_BGR2GRAY);
  for (const cv::Mat& image : {scene_bgr(), grey, cv::Mat(scene_bgr(), cv::Rect(7, 5, 201, 99))}) {
    for (int quality : {80, 92, 95}) {
      SCOPED_TRACE(fmt::format("{} channel(s), {}x{}, quality {}", image.channels(), image.cols, image.rows, quality));
      const auto ours = encode_jpeg(image, quality);
      ASSERT_TRUE(ours) << ours.error().message;
      std::vector<std::uint8_t> opencv;
      ASSERT_TRUE(cv::imencode(".jpg", image, opencv, {cv::IMWRITE_JPEG_QUALITY, quality}));
      EXPECT_EQ(ours.value(), opencv);
    }
  }
}

// The export's path: one buffer reused picture after picture, grown when a JPEG outgrows it (pure noise
// at quality 100 is larger than the room reserved), the same bytes every time.
TEST(ImageFiles, AJpegIntoAReusedBufferIsTheSameBytes) {
  cv::Mat noise(720, 1280, CV_8UC3);
  cv::randu(noise, 0, 256);
  std::vector<std::uint8_t> buffer;
  for (const auto& [image, quality] : std::vector<std::pair<cv::Mat, int>>{
           {scene_bgr(), 95}, {noise, 100}, {cv::Mat(scene_bgr(), cv::Rect(7, 5, 201, 99)), 80}, {scene_bgr(), 95}}) {
    SCOPED_TRACE(fmt::format("{}x{}, quality {}", image.cols, image.rows, quality));
    const auto size = encode_jpeg_into(image, quality, buffer);
    ASSERT_TRUE(size) << size.error().message;
    std::vector<std::uint8_t> opencv;
    ASSERT_TRUE(cv::imencode(".jpg", image, opencv, {cv::IMWRITE_JPEG_QUALITY, quality}));
    ASSERT_EQ(size.value(), opencv.size());
    EXPECT_TRUE(std::equal(opencv.begin(), opencv.end(), buffer.begin()));
    if (quality == 100) {
      EXPECT_GT(size.value(), noise.total() * 3 / 2 + 65536) << "the buffer was not outgrown";
    }
  }
}

TEST(ImageFiles, APngDecodesToThePictureItWasMadeFrom) {
  const cv::Mat bgr = scene_bgr();
  cv::Mat grey, bgra;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  cv::cvtColor(bgr, bgra, cv::COLOR_BGR2BGRA);
  bgra.col(3).setTo(cv::Scalar(10, 20, 30, 128));
  const cv::Mat strided(bgr, cv::Rect(3, 2, 150, 77));
  for (const cv::Mat& image : {bgr, grey, bgra, strided}) {
    SCOPED_TRACE(fmt::format("{} channel(s), {}x{}", image.channels(), image.cols, image.rows));
    const auto png = encode_png(image);
    ASSERT_TRUE(png) << png.error().message;
    const cv::Mat back = cv::imdecode(png.value(), cv::IMREAD_UNCHANGED);
    EXPECT_TRUE(same(back, image));
  }
}

TEST(ImageFiles, WhatCannotBeWrittenIsNamed) {
  const auto wide = encode_jpeg(cv::Mat(4, 4, CV_16UC1, cv::Scalar(1)), 90);
  ASSERT_FALSE(wide);
  EXPECT_NE(wide.error().message.find("16 bits"), std::string::npos) << wide.error().message;
  EXPECT_FALSE(encode_jpeg(cv::Mat(), 90));
  EXPECT_FALSE(encode_png(cv::Mat(4, 4, CV_8UC2)));

  const fs::path dir = fs::temp_directory_path() / fmt::format("pvcap-image-files-{}", getpid());
  fs::create_directories(dir);
  const cv::Mat bgr = scene_bgr();
  const Status tiff = write_image(dir / "view.tiff", bgr);
  ASSERT_FALSE(tiff.ok());
  EXPECT_NE(tiff.error().message.find("view.tiff"), std::string::npos) << tiff.error().message;
  const Status missing = write_image(dir / "no-such-folder" / "view.png", bgr);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("no-such-folder/view.png"), std::string::npos) << missing.error().message;
  ASSERT_TRUE(write_image(dir / "view.PNG", bgr).ok());
  EXPECT_TRUE(same(cv::imread((dir / "view.PNG").string(), cv::IMREAD_UNCHANGED), bgr));
  ASSERT_TRUE(write_image(dir / "view.jpg", bgr).ok());
  EXPECT_EQ(cv::imread((dir / "view.jpg").string()).size(), bgr.size());
  fs::remove_all(dir);
}
