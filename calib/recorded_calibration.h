#pragma once
// The pad calibration a recorded session holds for each camera: the newest `calibrations` row whose
// camera entry carries the pad's pose (recorded at the start from the rig's calibration file, or
// added later by `pvcap calibrate pad`). What the report's overlays and the export's camera
// geometry are computed through. (calib/session_calibration.h makes calibrations; this reads one.)
#include <optional>
#include <vector>

#include "calib/rig_calibration.h"
#include "core/result.h"
#include "storage/index/session_reader.h"

namespace pvcap::calib {

// By camera, in SessionReader::cameras() order; empty where the session has no pad calibration.
Result<std::vector<std::optional<CameraCalibration>>> pad_calibrations(SessionReader& r);

}  // namespace pvcap::calib
