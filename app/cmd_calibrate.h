#pragma once
// `pvcap calibrate board|intrinsics|pad|check`: the printable board, each camera's intrinsics from
// a board session, the pad's pose and homography from any session that shows the mat, and the
// press check of a calibration against a session's presses. Results
// go into the rig calibration file (calib/rig_calibration.h) and into the session's calibrations
// table. With a simulated run's ground truth, also the errors against it (exit 1 above target).
#include <filesystem>
#include <optional>
#include <string>

namespace pvcap {

struct CalibrateOptions {
  std::filesystem::path session;
  std::filesystem::path calibration;   // the rig calibration file to read/update
  std::filesystem::path ground_truth;  // a simulated run's sim-truth/ (empty: none)
  int frames = 0;                      // frames per camera to use (0: the command's default)
};

int cmd_calibrate_board(const std::filesystem::path& out);
int cmd_calibrate_intrinsics(const CalibrateOptions& options);
int cmd_calibrate_pad(const CalibrateOptions& options);
int cmd_calibrate_check(const CalibrateOptions& options);

}  // namespace pvcap
