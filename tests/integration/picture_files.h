#pragma once
// Reading back the JPEG and PNG files pvcap writes (exports, snapshots, the board), through
// libjpeg-turbo and libpng as pvcap writes them: the test binary does not load OpenCV's imgcodecs,
// whose GDAL build brings ~75 more libraries (0.12 s) into every test process.
#include <filesystem>

#include <opencv2/core.hpp>

namespace pvcap::testing {

// `file` (.jpg/.jpeg or .png) as 8-bit BGR, or grey when `grey`; empty when it cannot be read.
cv::Mat read_picture(const std::filesystem::path& file, bool grey = false);

}  // namespace pvcap::testing
