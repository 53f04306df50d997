// The capture checksum is the CRC-32 of the picture the raw video stores (the mosaic's planes
// stacked), so a decoded frame and a third party's ffmpeg framehash give the same number.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "storage/video/bayer_planes.h"
#include "storage/video/frame_checksum.h"

using namespace pvcap;

TEST(FrameChecksum, IsTheIeeeCrc32) {
  const char check[] = "123456789";  // the CRC-32 catalogue's check value
  EXPECT_EQ(crc32_of(check, 9), 0xcbf43926u);
}

TEST(FrameChecksum, AMosaicsChecksumIsThatOfItsStoredPlanes) {
  for (const int type : {CV_8UC1, CV_16UC1}) {
    cv::Mat mosaic(108, 192, type);
    cv::randu(mosaic, 0, type == CV_8UC1 ? 256 : 4096);
    cv::Mat planes;
    pack_bayer_planes(mosaic, planes);
    EXPECT_EQ(stored_mosaic_crc(mosaic), picture_crc(planes)) << cv::typeToString(type);
    // A view into a larger image (rows with padding) checksums the same as its copy.
    cv::Mat wide(108, 256, type);
    cv::randu(wide, 0, 200);
    const cv::Mat view = wide.colRange(32, 224);
    EXPECT_EQ(stored_mosaic_crc(view), stored_mosaic_crc(view.clone()));
    // One bit of one sample changes it.
    cv::Mat flipped = mosaic.clone();
    if (type == CV_8UC1)
      flipped.at<std::uint8_t>(5, 7) ^= 1;
    else
      flipped.at<std::uint16_t>(5, 7) ^= 1;
    EXPECT_NE(stored_mosaic_crc(flipped), stored_mosaic_crc(mosaic));
  }
}
