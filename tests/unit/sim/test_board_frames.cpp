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
// Waits (at most 10 s) until the renderer has `pose` ready.
bool wait_rendered(const sim::BoardFrames& frames, int pose) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!frames.rendered(pose) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  return frames.rendered(pose);
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
  // engine is given the newest pose rendered up to it, pose 1, at once, rather than waiting for 5.
  ASSERT_TRUE(wait_rendered(frames, 1)) << "pose 1 rendered ahead within 10 s";
  EXPECT_TRUE(equal_pixels(frames.frame(5), frames.render(1)));
  EXPECT_EQ(frames.poses_shown(), 2);
  // Asked for, it is rendered on the renderer's thread, the same as rendered here.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  cv::Mat got = frames.frame(5);
  while (!equal_pixels(got, pose5) && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    got = frames.frame(5);
  }
  EXPECT_TRUE(equal_pixels(got, pose5)) << "pose 5 rendered within 10 s";
  EXPECT_EQ(frames.poses_shown(), 3);
  // Poses only move forward: a later look at an earlier instant keeps the board where it is.
  EXPECT_TRUE(equal_pixels(frames.frame(3), pose5));
}

// A renderer slower than the poses change (a loaded machine) still moves the board: a pose that
// was rendered after the engine moved past it is shown, rather than the board held where it was
// until a render finishes in time (which, at that pace, none does).
TEST(BoardFrames, APoseRenderedLateIsShownRatherThanTheBoardHeldStill) {
  const cv::Size size(480, 270);
  const calib::CameraModel m = sim::sim_camera_model(1, sim::SimCameraClock{}, size, size);
  sim::BoardFrames frames(m, "BayerRG8", 0);
  ASSERT_TRUE(wait_rendered(frames, 1)) << "pose 1 rendered ahead within 10 s";
  // The engine is at pose 3 already: pose 1 is the newest rendered, and the renderer starts on 3 and 4.
  EXPECT_TRUE(equal_pixels(frames.frame(3), frames.render(1)));
  ASSERT_TRUE(wait_rendered(frames, 4)) << "poses 3 and 4 rendered within 10 s";
  // Both came too late for pose 3's frames; the engine is at pose 9 now, which nobody rendered:
  // the newest of them is shown.
  EXPECT_TRUE(equal_pixels(frames.frame(9), frames.render(4)));
  EXPECT_EQ(frames.poses_shown(), 3);  // 0, 1, 4
}
