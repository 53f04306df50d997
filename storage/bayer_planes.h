#pragma once
// The raw store's picture layout: a W x H Bayer mosaic kept as its four colour planes, each
// W/2 x H/2, stacked top to bottom in the order of the 2x2 cell (top-left, top-right,
// bottom-left, bottom-right) into one W/2 x 2H grey picture. A lossless codec then sees four
// smooth images instead of a mosaic whose neighbouring samples are different colours: FFmpeg's
// HuffYUV codes the planes in a third of the mosaic's size (docs/store.md, "Raw video").
#include <opencv2/core.hpp>

namespace pvcap {

inline constexpr const char* kBayerPlanesLayout = "bayer_planes";

// The stacked picture's size for a mosaic of `mosaic` size (width and height must be even).
inline cv::Size bayer_planes_size(cv::Size mosaic) { return {mosaic.width / 2, mosaic.height * 2}; }

// `mosaic` (CV_8UC1 or CV_16UC1, even size) into `planes` (same depth, bayer_planes_size), which
// may be a view of a codec's buffer: it is written in place when its size and type already fit.
void pack_bayer_planes(const cv::Mat& mosaic, cv::Mat& planes);
// The inverse: `planes` back into `mosaic` (allocated when its size or type do not fit).
void unpack_bayer_planes(const cv::Mat& planes, cv::Mat& mosaic);

}  // namespace pvcap
