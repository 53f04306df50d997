#pragma once
// The board views a lens fit works from (corners found per frame, calib/charuco.h), kept as a
// YAML file: what `pvcap calibrate intrinsics --save-views DIR` writes for each camera, so that a
// fit that fails on a lab's rig can be fitted again elsewhere, and what the tests' fixtures of
// failing fits are.
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "calib/charuco.h"
#include "core/result.h"

namespace pvcap::calib {

struct BoardViews {
  cv::Size image_size;
  std::vector<BoardView> views;  // in the order they were seen; a view may have no corners
};

Status save_board_views(const std::filesystem::path& file, const BoardViews& views);
// One clear error naming the file and what is wrong with it.
Result<BoardViews> load_board_views(const std::filesystem::path& file);
// The same from a file's text; errors name `source`.
Result<BoardViews> parse_board_views(const std::string& text, const std::string& source);

}  // namespace pvcap::calib
