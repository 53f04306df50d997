#pragma once
// What `pvcap calibrate board|intrinsics|pad|check` does: the printable board, each camera's
// intrinsics from a board session, the pad's pose and homography from any session that shows the
// mat, and the press check of a calibration against a session's presses. Results go into the rig
// calibration file (calib/rig_calibration.h) and into the session's calibrations table, and are
// printed per camera as they come (progress on a terminal). Given a reference calibration (an
// earlier calibration of the rig, or, on a simulated rig, the simulator's truth that app/ reads),
// also the errors against it. Each returns the command's exit code: 1 when a camera failed or
// missed a target against the reference (what succeeded is saved); a user's mistake throws UserError.
// The one part of calib/ that reads a store: a library of its own (pvcap_calib_session).
#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "calib/camera_model.h"
#include "calib/rig_calibration.h"

namespace pvcap::calib {

// What a new calibration is compared against, camera by camera.
struct ReferenceCamera {
  std::string name;
  CameraModel model;                          // lens and (for the pad) pose
  std::array<cv::Point2d, 4> pad_corners_px;  // the grid's outer edges in the image as sent
};
struct ReferenceCalibration {
  std::string label;  // how the printout names it: "the truth", or the file it came from
  std::vector<ReferenceCamera> cameras;
  const ReferenceCamera* camera(const std::string& name) const;
};

// An earlier calibration as a reference (cameras with intrinsics; pad corners where a pose was solved,
// otherwise projected through the model).
ReferenceCalibration reference_from(const RigCalibration& calibration, std::string label);

struct SessionCalibrationOptions {
  std::filesystem::path session;
  std::filesystem::path calibration;              // the rig calibration file to read/update
  std::optional<ReferenceCalibration> reference;  // compare against it and hold the targets (none: no comparison)
  int frames = 0;                                 // frames per camera to use (0: the command's default)
  std::filesystem::path save_views;               // intrinsics: each camera's board views written here (a fit elsewhere)
};

int write_board(const std::filesystem::path& out);  // .pdf or .png
int intrinsics_from_session(const SessionCalibrationOptions& options);
int pad_from_session(const SessionCalibrationOptions& options);
int check_against_presses(const SessionCalibrationOptions& options);

}  // namespace pvcap::calib
