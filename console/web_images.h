#pragma once
// The pictures the operator's page shows: a camera's preview as JPEG, the latest pressure frame as a
// heat map PNG (black no pressure, then inferno up to kHeatMapMaxKpa on the native grid, scaled up).
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "session/recording_status.h"

namespace pvcap::console {

inline constexpr double kHeatMapMaxKpa = 60;  // the heat map's top colour

// nullopt: no image (none yet, or it cannot be encoded).
std::optional<std::string> camera_jpeg(const cv::Mat& image, bool full);
std::optional<std::string> pressure_png(const session::PressureSnapshot& pressure);

}  // namespace pvcap::console
