#pragma once
// A calibration board session on the simulated rig: the ChArUco board (calib/charuco.h) held
// still in one pose after another over and around the pad, tilted and turned, so that every
// camera sees it across its view. Each pose is held for kBoardHoldSeconds (an operator holds
// the board still; a moving board blurs), and every hold is a pose of its own (board_pose). 0.25 s:
// a 25 s board session shows 100 poses, 75 when its first 6 s are lost (a loaded PC starting four
// simulated 1080p cameras loses 4-6 s). With the 48 poses at 0.4 s repeating, the principal point
// came out 1.5-2.2 px off (target 2; a pose renders the same each time it recurs, so a repeat tells
// the fit nothing); 0.06-0.88 px with 100, with the corner refinement's wider window and the
// outlier views left out until none is (calib/charuco.cpp; docs/calibration.md).
#include <opencv2/core.hpp>

namespace pvcap::sim {

constexpr int kBoardPoses = 48;
constexpr double kBoardHoldSeconds = 0.25;

// The board's frame (mm; x along the printed page's rows, y down the page, z into the board)
// in the pad frame, for hold `hold`: the lattice's pose hold % kBoardPoses, moved in each round.
struct BoardPose {
  cv::Matx33d R;
  cv::Vec3d t;
};
BoardPose board_pose(int hold, double board_w_mm, double board_h_mm);
// The hold shown at `seconds` (0, 1, 2...: each a pose of its own, see board_pose).
inline int board_pose_index(double seconds) { return int(seconds / kBoardHoldSeconds); }

}  // namespace pvcap::sim

#include <random>
#include <vector>

namespace pvcap::sim {

// The holds one camera's frames show in a board session drawn by `rng`, as `pvcap calibrate
// intrinsics` reads them: the recording's first `lost_s` seconds lost (a loaded PC starting four
// 1080p cameras loses 4-6 s), the store's 15 Hz samples from there to `duration_s`, 150 of them
// spread evenly (the command's default), each camera's frame up to half a 30 Hz period either side of
// its sample's instant. Holds past `holds - 1` are clamped to it. For tests and benches that fit
// many board sessions without recording each (tests/unit/calib, bench/board_fit_bench).
std::vector<int> board_session_holds(std::mt19937& rng, double lost_s, double duration_s, int holds);

}  // namespace pvcap::sim
