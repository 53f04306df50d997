#include "console/web_images.h"

#include <algorithm>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "codec/image_files.h"
#include "codec/sensel_units.h"

namespace pvcap::console {

std::optional<std::string> camera_jpeg(const cv::Mat& image, bool full) {
  if (image.empty()) return {};
  auto jpg = encode_jpeg(image, full ? 92 : 80);
  if (!jpg) return {};
  return std::string(jpg.value().begin(), jpg.value().end());
}

std::optional<std::string> pressure_png(const session::PressureSnapshot& p) {
  if (p.counts.empty() || int(p.counts.size()) != p.grid.cells()) return {};
  cv::Mat level(p.grid.rows, p.grid.cols, CV_8U);
  for (int r = 0; r < p.grid.rows; ++r)
    for (int c = 0; c < p.grid.cols; ++c) {
      const double kpa = sensel::native_cell_kpa(p.counts[std::size_t(r * p.grid.cols + c)], p.grid);
      level.at<std::uint8_t>(r, c) = static_cast<std::uint8_t>(std::clamp(kpa / kHeatMapMaxKpa, 0.0, 1.0) * 255);
    }
  cv::Mat colour;
  cv::applyColorMap(level, colour, cv::COLORMAP_INFERNO);
  colour.setTo(cv::Scalar(0, 0, 0), level == 0);
  cv::resize(colour, colour, {}, 4, 4, cv::INTER_NEAREST);
  auto png = encode_png(colour);
  if (!png) return {};
  return std::string(png.value().begin(), png.value().end());
}

}  // namespace pvcap::console
