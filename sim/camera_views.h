#pragma once
// Where each simulated camera stands and what lens it has: the rig file's sim.cameras[i]
// (position_mm, look_at_mm, focal_px, distortion), or four plausible defaults (from above,
// from the left, from the right, from the participant's side), as a calib::CameraModel.
#include <opencv2/core.hpp>

#include "calib/camera_model.h"
#include "core/rig_config.h"
#include "sim/sim_config.h"

namespace pvcap::sim {

// The model of camera `index` for images of `size`; `configured` is the rig file's image size
// (focal length and principal point scale with the image when a camera is set to another size).
calib::CameraModel sim_camera_model(int index, const SimCameraClock& config, cv::Size configured, cv::Size size);

}  // namespace pvcap::sim
