#pragma once
// A board session's frames for one camera view (sim/board_motion.h), rendered a pose ahead on a
// thread of their own.
//
// A pose's frame takes the board drawn through every pixel's ray (15 ms for a 1080p view alone, on
// all cores; several times that with four cameras changing pose at the same instant). Rendered on
// the fake-camera engine's thread, as it once was, the engine missed its next frame instant and
// skipped whole periods: an idle board session's four cameras sent 120-137 of their 180 frames,
// with gaps of 130-270 ms at pose changes and 500-735 ms at the start, and two such sessions
// started side by side had every camera silent long enough to be called lost. A real camera's
// frames leave on time whatever it looks at; here the engine only copies a rendered frame.
#include <condition_variable>
#include <map>
#include <mutex>
#include <string>
#include <thread>

#include <opencv2/core.hpp>

#include "calib/camera_model.h"

namespace pvcap::sim {

class BoardFrames {
 public:
  // Renders `first_pose` before returning (a session's first frame waits for nothing), then the
  // next pose on the renderer's thread.
  BoardFrames(const calib::CameraModel& model, std::string pixel_format, int first_pose);
  ~BoardFrames();
  BoardFrames(const BoardFrames&) = delete;
  BoardFrames& operator=(const BoardFrames&) = delete;

  // The frame (sensor format) of the newest pose rendered up to `pose`: `pose` itself once rendered;
  // else a pose rendered late, after the engine had already moved past it; else the pose shown last.
  // The board is held a little longer rather than a frame sent late, and a renderer that stays
  // slower than the poses change still moves the board. Asks the renderer for `pose` and the one
  // after. Poses only move forward: an older pose than the one shown is answered with the shown.
  cv::Mat frame(int pose);
  // How many poses have been shown (rendered in time for at least one frame).
  int poses_shown() const;
  // Whether `pose` is rendered and not yet passed (for tests: the renderer's progress).
  bool rendered(int pose) const;

  // The frame of `pose` rendered here and now (what the renderer's thread does).
  cv::Mat render(int pose) const;

 private:
  void run();

  const calib::CameraModel model_;
  const std::string pixel_format_;
  cv::Mat rays_, scene_bgr_;  // set before the thread starts, read-only after

  mutable std::mutex mu_;
  std::condition_variable wake_;
  std::map<int, cv::Mat> frames_;  // rendered: the pose shown and at most two ahead
  int shown_ = -1, wanted_ = -1, poses_shown_ = 0;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace pvcap::sim
