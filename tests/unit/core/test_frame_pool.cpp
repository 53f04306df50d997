#include "core/frame_pool.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

using pvcap::FramePool;

TEST(FramePool, ABufferDroppedByItsConsumerIsHandedOutAgain) {
  FramePool pool(4);
  const std::uint8_t* first = nullptr;
  {
    cv::Mat a = pool.acquire(1080, 1920, CV_8UC3);
    first = a.data;
    cv::Mat in_queue = std::move(a);  // the consumer's handle
  }                                   // ...dropped when it is done
  cv::Mat again = pool.acquire(1080, 1920, CV_8UC3);
  EXPECT_EQ(again.data, first);
  EXPECT_EQ(pool.size(), 1u);
}

TEST(FramePool, ABufferStillHeldIsNeverHandedOut) {
  FramePool pool(4);
  cv::Mat a = pool.acquire(10, 20, CV_8UC3);
  cv::Mat b = pool.acquire(10, 20, CV_8UC3);
  EXPECT_NE(a.data, b.data);
  cv::Mat a_in_queue = a;  // two holders: still not free once the worker's own handle goes
  a.release();
  cv::Mat c = pool.acquire(10, 20, CV_8UC3);
  EXPECT_NE(c.data, a_in_queue.data);
  EXPECT_NE(c.data, b.data);
  EXPECT_EQ(pool.size(), 3u);
}

TEST(FramePool, WritingIntoAnAcquiredImageKeepsItsBuffer) {
  // cvtColor into an image of the right size and type writes in place: the pool's buffer is used.
  FramePool pool(2);
  cv::Mat bgr = pool.acquire(8, 8, CV_8UC3);
  const std::uint8_t* buffer = bgr.data;
  const cv::Mat bayer(8, 8, CV_8UC1, cv::Scalar(100));
  cv::cvtColor(bayer, bgr, cv::COLOR_BayerBG2BGR);
  EXPECT_EQ(bgr.data, buffer);
}

TEST(FramePool, BeyondCapacityImagesAreFreshAndNotKept) {
  FramePool pool(2);
  cv::Mat a = pool.acquire(4, 4, CV_8UC1), b = pool.acquire(4, 4, CV_8UC1), c = pool.acquire(4, 4, CV_8UC1);
  EXPECT_EQ(pool.size(), 2u);
  EXPECT_NE(c.data, a.data);
  EXPECT_NE(c.data, b.data);
}

TEST(FramePool, ANewSizeTakesTheRoomOfAFreeBufferOfTheOldSize) {
  FramePool pool(1);
  { cv::Mat small = pool.acquire(4, 4, CV_8UC3); }
  cv::Mat big = pool.acquire(8, 8, CV_8UC3);
  const std::uint8_t* buffer = big.data;
  big.release();
  EXPECT_EQ(pool.acquire(8, 8, CV_8UC3).data, buffer);
  EXPECT_EQ(pool.size(), 1u);
}
