#pragma once
// A calibration board session on the simulated rig: the ChArUco board (calib/charuco.h) held
// still in one pose after another over and around the pad, tilted and turned, so that every
// camera sees it across its view. Each pose is held for kBoardHoldSeconds (an operator holds
// the board still; a moving board blurs). Half a second: the 48 poses in 24 s, each in about three
// of the 150 frames `calibrate intrinsics` reads by default (1 s: about the same
// principal point margins, 1.5 px against 1.5-1.7 px, in twice the time).
#include <opencv2/core.hpp>

namespace pvcap::sim {

constexpr int kBoardPoses = 48;
constexpr double kBoardHoldSeconds = 0.5;

// The board's frame (mm; x along the printed page's rows, y down the page, z into the board)
// in the pad frame, for pose `index` (taken modulo kBoardPoses).
struct BoardPose {
  cv::Matx33d R;
  cv::Vec3d t;
};
BoardPose board_pose(int index, double board_w_mm, double board_h_mm);
inline int board_pose_index(double seconds) { return int(seconds / kBoardHoldSeconds) % kBoardPoses; }

}  // namespace pvcap::sim
