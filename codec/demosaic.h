#pragma once
// Bayer mosaics to colour, by pattern name: one place for the pattern arithmetic, used by the
// capture path (previews, colour video) and by the store's readers (raw video). No Aravis here, so
// readers and their fuzz targets link without it.
#include <string>
#include <string_view>

#include <opencv2/core.hpp>

#include "core/result.h"

namespace pvcap {

// How a Bayer mosaic becomes colour: OpenCV's bilinear (the capture path's and the default),
// its edge-aware variant, VNG (8-bit only), or half size: each 2x2 cell one pixel (its R, the mean
// of its two G, its B), no interpolation at all: a W/2 x H/2 image, for previews and replays.
enum class Demosaic { Bilinear, EdgeAware, Vng, HalfSize };
const char* to_string(Demosaic d);
// "bilinear", "edge-aware", "vng"; an Error naming the choices otherwise.
Result<Demosaic> parse_demosaic(const std::string& name);

// The 2x2 pattern of a Bayer format as PFNC names it ("BayerRG8" -> "RG"); empty for any other name.
std::string_view bayer_pattern(std::string_view bayer_format);

// Demosaics `mosaic` (CV_8UC1 or CV_16UC1, one Bayer pattern named as PFNC names it, e.g. "BayerRG8")
// into `bgr` (CV_8UC3 or CV_16UC3).
Status debayer(const cv::Mat& mosaic, const std::string& bayer_format, Demosaic method, cv::Mat& bgr);
// Demosaic::HalfSize from the cell's four planes (top-left, top-right, bottom-left, bottom-right),
// each W/2 x H/2: what a raw video already holds, so it needs no splitting. One green may be empty
// (a reader that decoded three planes): the other is then the green alone.
Status half_size_from_planes(const cv::Mat planes[4], const std::string& bayer_format, cv::Mat& bgr);
// The same scaled to `size` (bilinear). Exactly two thirds of the half size (a 1080p mosaic's 960 x 540
// to 640 x 360, a replay's view) is one pass straight from the planes, no half-size image in
// between; any other size is the half-size image resized.
Status scaled_half_size_from_planes(const cv::Mat planes[4], const std::string& bayer_format, cv::Size size,
                                    cv::Mat& bgr);
// Three 8-bit grey planes (blue, green, red; W x H, both multiples of 3) as one colour image two
// thirds their size each way, bilinear: each 3 x 3 block becomes 2 x 2 pixels, each 9:3:3:1 / 16 of
// its four nearest source pixels, rounded half up (cv::resize's INTER_LINEAR puts its output pixels
// at the same places and differs from this by at most 1).
void two_thirds_bgr(const cv::Mat planes_bgr[3], cv::Mat& bgr);

}  // namespace pvcap
