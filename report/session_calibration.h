#pragma once
// The calibration a recorded session holds for each camera: the newest `calibrations` row whose
// camera entry carries the pad's pose (recorded at the start from the rig's calibration file, or
// added later by `pvcap calibrate pad`). What the report's overlays and the export's camera
// geometry are computed through.
#include <optional>
#include <vector>

#include "calib/rig_calibration.h"
#include "core/result.h"
#include "storage/session_reader.h"

namespace pvcap::report {

// By camera, in SessionReader::cameras() order; empty where the session has no pad calibration.
Result<std::vector<std::optional<calib::CameraCalibration>>> pad_calibrations(SessionReader& r);

}  // namespace pvcap::report
