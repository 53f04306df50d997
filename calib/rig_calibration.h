#pragma once
// The rig calibration file (YAML): each camera's intrinsics and, once the pad is calibrated, its
// pose relative to the pad, with how each was measured. `pvcap calibrate` writes it; later sessions
// and tools load it. Default place: beside the rig file, <rig>.calibration.yaml.
#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/camera_model.h"
#include "calib/pad_layout.h"
#include "core/result.h"

namespace pvcap::calib {

struct MeasuredBy {
  std::string method;   // charuco_intrinsics | pad_markers
  std::string session;  // the session folder it was measured from
  std::int64_t created_wall_ns = 0;
  double rms_px = 0;
  std::optional<double> rms_mm;
  nlohmann::json details = nlohmann::json::object();  // views, coverage, marker ids, ...
};

struct CameraCalibration {
  std::string name, serial;
  CameraModel model;  // intrinsics; the pose holds once `pad` is set
  std::optional<MeasuredBy> intrinsics, pad;
  std::optional<cv::Matx33d> cells_to_ideal;                 // with `pad`
  std::optional<std::array<cv::Point2d, 4>> pad_corners_px;  // with `pad`
};

struct RigCalibration {
  std::string rig;  // the rig's name
  PadLayout pad = default_pad_layout();
  std::vector<CameraCalibration> cameras;
  CameraCalibration* camera(const std::string& name);
};

std::filesystem::path default_calibration_path(const std::filesystem::path& rig_file);
// Errors name the file and what is wrong with it.
Result<RigCalibration> load_rig_calibration(const std::filesystem::path& path);
// The same from text; `source` names it in messages.
Result<RigCalibration> parse_rig_calibration(const std::string& text, const std::string& source);
// Written to a temporary file and renamed over `path`: a crash leaves the old file or the new one.
Status save_rig_calibration(const std::filesystem::path& path, const RigCalibration& calibration);

void to_json(nlohmann::json& j, const MeasuredBy& m);
void from_json(const nlohmann::json& j, MeasuredBy& m);
void to_json(nlohmann::json& j, const CameraCalibration& c);
void from_json(const nlohmann::json& j, CameraCalibration& c);
void to_json(nlohmann::json& j, const RigCalibration& c);
void from_json(const nlohmann::json& j, RigCalibration& c);

}  // namespace pvcap::calib
