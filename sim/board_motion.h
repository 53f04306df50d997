#pragma once
// A calibration board session on the simulated rig: the ChArUco board (calib/charuco.h) held
// still in one pose after another over and around the pad, tilted and turned, so that every
// camera sees it across its view. Each pose is held for kBoardHoldSeconds (an operator holds
// the board still; a moving board blurs). 0.4 s: the 48 poses in 19.2 s, so a 25 s board session
// still shows every pose when its first seconds are lost (a loaded PC starting four simulated
// 1080p cameras lost 4-6 s of a session's start, and with them a fifth of the poses: a principal
// point 2.06 px off, target 2); each pose is in about two of the 150 frames `calibrate
// intrinsics` reads by default. (1 s: about the same principal point margins, 1.5 px against
// 1.5-1.7 px at 0.5 s, in twice the time.)
#include <opencv2/core.hpp>

namespace pvcap::sim {

constexpr int kBoardPoses = 48;
constexpr double kBoardHoldSeconds = 0.4;

// The board's frame (mm; x along the printed page's rows, y down the page, z into the board)
// in the pad frame, for pose `index` (taken modulo kBoardPoses).
struct BoardPose {
  cv::Matx33d R;
  cv::Vec3d t;
};
BoardPose board_pose(int index, double board_w_mm, double board_h_mm);
inline int board_pose_index(double seconds) { return int(seconds / kBoardHoldSeconds) % kBoardPoses; }

}  // namespace pvcap::sim
