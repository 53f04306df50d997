#pragma once
// What `pvcap calibrate board|intrinsics|pad|check` does: the printable board, each camera's
// intrinsics from a board session, the pad's pose and homography from any session that shows the
// mat, and the press check of a calibration against a session's presses. Results go into the rig
// calibration file (calib/rig_calibration.h) and into the session's calibrations table, and are
// printed per camera as they come (progress on a terminal). With a simulated run's ground truth,
// also the errors against it. Each returns the command's exit code: 1 when a camera failed or
// missed a target (what succeeded is saved); a user's mistake throws UserError.
// The one part of calib/ that reads a store: a library of its own (pvcap_calib_session).
#include <filesystem>
#include <optional>
#include <string>

namespace pvcap::calib {

struct SessionCalibrationOptions {
  std::filesystem::path session;
  std::filesystem::path calibration;   // the rig calibration file to read/update
  std::filesystem::path ground_truth;  // a simulated run's sim-truth/ (empty: none)
  int frames = 0;                      // frames per camera to use (0: the command's default)
};

int write_board(const std::filesystem::path& out);  // .pdf or .png
int intrinsics_from_session(const SessionCalibrationOptions& options);
int pad_from_session(const SessionCalibrationOptions& options);
int check_against_presses(const SessionCalibrationOptions& options);

}  // namespace pvcap::calib
