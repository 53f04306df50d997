#pragma once
// Reading what the simulator says really happened (the sim-truth/ folder beside a simulated run):
// rig.json's cameras (model, pad corners in the image) and the per-frame CSV logs. The simulator
// writes them (sim_rig, sim_camera); tools and tests that check against them read them here.
#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "calib/camera_model.h"
#include "calib/pad_layout.h"
#include "core/result.h"

namespace pvcap::sim {

struct CameraTruth {
  std::string name;
  calib::CameraModel model;                   // K, distortion and pose the simulator rendered with
  std::array<cv::Point2d, 4> pad_corners_px;  // the grid's outer edges in the image as sent
};

struct RigTruth {
  std::int64_t t0_ns = 0;  // the simulator's start, CLOCK_MONOTONIC
  calib::PadLayout pad;
  std::vector<CameraTruth> cameras;
  const CameraTruth* camera(const std::string& name) const;
};

// truth_dir/rig.json; an Error names the file and what is wrong.
Result<RigTruth> read_rig_truth(const std::filesystem::path& truth_dir);

// A truth CSV (header, then rows of integers) as column `key` -> column `value` (keys masked with
// `key_mask`, e.g. 16-bit frame ids).
Result<std::map<std::int64_t, std::int64_t>> read_truth_columns(const std::filesystem::path& csv,
                                                                const std::string& key, const std::string& value,
                                                                std::int64_t key_mask = -1);

}  // namespace pvcap::sim
