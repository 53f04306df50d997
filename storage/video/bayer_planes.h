#pragma once
// The raw store's picture layout: a W x H Bayer mosaic kept as its four colour planes, each
// W/2 x H/2, stacked top to bottom into one W/2 x 2H grey picture. A lossless codec then sees four
// smooth images instead of a mosaic whose neighbouring samples are different colours: FFmpeg's
// HuffYUV codes the planes in a third of the mosaic's size (docs/store.md, "Raw video").
// Two stacking orders, named in each video's layout:
//   - "bayer_planes": the 2x2 cell's top-left, top-right, bottom-left, bottom-right samples
//     (what pvcap wrote before 2026-11-28);
//   - "bayer_planes_green_last": the cell's first row, then its second row with the green last.
//     For every pattern the last plane is then a second green, which a half-size colour image does
//     not need: a HuffYUV decoder told the picture is 3/4 as tall decodes the first three planes
//     and stops (storage/video/video_reader.h), a quarter less decoding for the replay's views.
#include <array>
#include <cstdint>
#include <vector>
#include <string_view>

#include <opencv2/core.hpp>

#include "core/result.h"

namespace pvcap {

inline constexpr const char* kBayerPlanesLayout = "bayer_planes";
inline constexpr const char* kBayerPlanesGreenLastLayout = "bayer_planes_green_last";

// The cell each stacked plane holds, top to bottom (0 top-left, 1 top-right, 2 bottom-left,
// 3 bottom-right).
using PlaneOrder = std::array<int, 4>;
inline constexpr PlaneOrder kCellOrder{0, 1, 2, 3};

// Whether `layout` is a raw video's (one of the two above).
bool is_bayer_planes_layout(std::string_view layout);
// The order of `layout` for the pattern of `bayer_format` (PFNC's name, "BayerRG8"); an Error for a
// layout or pattern pvcap does not know.
Result<PlaneOrder> plane_order(std::string_view layout, std::string_view bayer_format);

// The stacked picture's size for a mosaic of `mosaic` size (width and height must be even).
inline cv::Size bayer_planes_size(cv::Size mosaic) { return {mosaic.width / 2, mosaic.height * 2}; }

// `mosaic` (CV_8UC1 or CV_16UC1, even size) into `planes` (same depth, bayer_planes_size), which
// may be a view of a codec's buffer: it is written in place when its size and type already fit.
void pack_bayer_planes(const cv::Mat& mosaic, cv::Mat& planes, const PlaneOrder& order = kCellOrder);
// How often each left-prediction residual (the sample minus the one before it in its row, mod 256)
// occurs in an 8-bit picture, added to `counts` (256 of them): what HuffYUV's tables code.
void add_left_residual_counts(const cv::Mat& picture, std::vector<std::uint64_t>& counts);
// The inverse: `planes` back into `mosaic` (allocated when its size or type do not fit).
void unpack_bayer_planes(const cv::Mat& planes, cv::Mat& mosaic, const PlaneOrder& order = kCellOrder);

}  // namespace pvcap
