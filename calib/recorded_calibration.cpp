#include "calib/recorded_calibration.h"

#include <nlohmann/json.hpp>

namespace pvcap::calib {

Result<std::vector<std::optional<CameraCalibration>>> pad_calibrations(SessionReader& r) {
  auto rows = r.calibrations();
  if (!rows) return rows.error();
  std::vector<std::optional<CameraCalibration>> out(r.cameras().size());
  for (std::size_t c = 0; c < r.cameras().size(); ++c)
    for (const auto& row : rows.value()) {  // oldest first: the last with a pose wins
      if (row.device_id != r.cameras()[c].device_id) continue;
      try {
        auto cal = nlohmann::json::parse(row.details_json).get<CameraCalibration>();
        if (cal.pad && cal.pad_corners_px) out[c] = std::move(cal);
      } catch (const std::exception&) {
        // A row without a readable camera entry (older or foreign) says nothing about the pose.
      }
    }
  return out;
}

}  // namespace pvcap::calib
