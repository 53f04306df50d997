// The board session's frames are rendered ahead of the fake-camera engine (sim/board_frames.h): the
// engine gets a rendered pose at once, never waits for one, and the frames are the renders exactly.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "sim/board_frames.h"
#include "sim/camera_views.h"

using namespace pvcap;

namespace {
bool equal_pixels(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::countNonZero(a != b) == 0;
}
}  // namespace

TEST(BoardFrames, APoseNotRenderedYetHoldsTheLastOneAndThenComesExact) {
  const cv::Size size(480, 270);
  const calib::CameraModel m = sim::sim_camera_model(2, sim::SimCameraClock{}, size, size);
  sim::BoardFrames frames(m, "BayerRG8", 0);
  const cv::Mat pose0 = frames.render(0), pose5 = frames.render(5);
  ASSERT_FALSE(equal_pixels(pose0, pose5)) << "two poses of the board look different";
  EXPECT_TRUE(equal_pixels(frames.frame(0), pose0)) << "the first pose is rendered before the engine starts";
  // Pose 5 was never asked for (the renderer works one pose ahead of the last asked: pose 1), so the
  // engine is given pose 0 again, at once, rather than waiting.
  EXPECT_TRUE(equal_pixels(frames.frame(5), pose0));
  EXPECT_EQ(frames.poses_shown(), 1);
  // Asked for, it is rendered on the renderer's thread, the same as rendered here.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  cv::Mat got = frames.frame(5);
  while (!equal_pixels(got, pose5) && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    got = frames.frame(5);
  }
  EXPECT_TRUE(equal_pixels(got, pose5)) << "pose 5 rendered within 10 s";
  EXPECT_EQ(frames.poses_shown(), 2);
  // Poses only move forward: a later look at an earlier instant keeps the board where it is.
  EXPECT_TRUE(equal_pixels(frames.frame(3), pose5));
}
