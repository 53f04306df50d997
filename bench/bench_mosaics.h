// The benchmarks' 1080p camera frames: the simulator's scene as the sensor's Bayer mosaic, a
// fingertip moving across it, and sensor noise (bench/store_bench, bench/lossless_bench).
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "sim/scene.h"

namespace pvcap::bench {

inline constexpr int kMosaicWidth = 1920, kMosaicHeight = 1080;

// `n` BayerRG8 frames of camera `cam` with `noise` DN of sensor noise (standard deviation; 0: the
// simulator's clean image).
inline std::vector<cv::Mat> make_mosaics(int cam, int n, double noise) {
  const cv::Size size(kMosaicWidth, kMosaicHeight);
  const cv::Mat bgr = sim::render_default_scene_bgr(cam, size, /*noise_dn=*/0);  // its own noise is added below
  const cv::Mat bayer = sim::to_sensor_format(bgr, "BayerRG8");
  std::vector<cv::Mat> out;
  cv::RNG rng(std::uint64_t(cam + 1));
  for (int i = 0; i < n; ++i) {
    cv::Mat f = bayer.clone();
    sim::draw_fingertip(f, "BayerRG8", {700.0 + 12 * i, 500.0 + 4 * i}, 40);
    if (noise > 0) {
      cv::Mat dn(f.size(), CV_8SC1);
      rng.fill(dn, cv::RNG::NORMAL, 0, noise);
      cv::add(f, dn, f, cv::noArray(), CV_8U);
    }
    out.push_back(f);
  }
  return out;
}

}  // namespace pvcap::bench
