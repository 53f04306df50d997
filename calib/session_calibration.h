#pragma once
// Calibration from recorded sessions: the printable board, each camera's intrinsics from a board
// session, the pad's pose and homography from any session that shows the mat, and the press check of
// a calibration against a session's presses. Results go into the rig calibration file
// (calib/rig_calibration.h) and into the session's calibrations table, and are told per camera as
// they come to the caller's sinks (`pvcap calibrate` prints them); nothing here prints. Given a
// reference calibration (an earlier calibration of the rig, or, on a simulated rig, the simulator's
// truth that app/ reads), also the errors against it. A user's mistake throws UserError. The one
// part of calib/ that reads a store: a library of its own (pvcap_calib_session).
#include <array>
#include <filesystem>
#include <functional>
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

// Where a calibration's results and progress go (unset: nowhere).
struct CalibrationSinks {
  std::function<void(const std::string& text)> say;   // results, as the operator reads them (lines)
  std::function<void(const std::string& line)> warn;  // a camera that failed, or a mark left out
  std::function<void(const std::string& what, std::size_t done, std::size_t total)> progress;
};

struct SessionCalibrationOptions {
  std::filesystem::path session;
  std::filesystem::path calibration;              // the rig calibration file to read/update
  std::optional<ReferenceCalibration> reference;  // compare against it and hold the targets (none: no comparison)
  int frames = 0;                                 // frames per camera to use (0: the command's default)
  std::filesystem::path save_views;  // intrinsics: each camera's board views written here (a fit elsewhere)
  CalibrationSinks sinks;
};

// Writes the board to print (.pdf or .png); returns what was written and how to print it.
std::string write_board(const std::filesystem::path& out);
// Each returns whether every camera succeeded (and, against a reference, met its targets); what
// succeeded is saved either way.
bool intrinsics_from_session(const SessionCalibrationOptions& options);
bool pad_from_session(const SessionCalibrationOptions& options);
bool check_against_presses(const SessionCalibrationOptions& options);

}  // namespace pvcap::calib
