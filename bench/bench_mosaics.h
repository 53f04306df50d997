// The benchmarks' 1080p camera frames: the simulator's scene as the sensor's Bayer mosaic, a
// fingertip moving across it, and sensor noise (bench/store_bench, bench/lossless_bench).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "sim/scene.h"

namespace pvcap::bench {

inline constexpr int kMosaicWidth = 1920, kMosaicHeight = 1080;
// The benches' sensor noise by default (standard deviation, DN): a real sensor's read noise.
inline constexpr double kSensorNoiseDn = 2.0;

// Adds `noise` DN (standard deviation) of Gaussian sensor noise to an 8-bit frame: drawn afresh for
// every sample, rounded to whole DN, the sum saturating at 0 and 255.
inline void add_sensor_noise(cv::Mat& frame, cv::RNG& rng, double noise) {
  cv::Mat dn(frame.size(), CV_8SC1);
  rng.fill(dn, cv::RNG::NORMAL, 0, noise);
  cv::add(frame, dn, frame, cv::noArray(), CV_8U);
}

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
    if (noise > 0) add_sensor_noise(f, rng, noise);
    out.push_back(f);
  }
  return out;
}

// Entropy in bits of one sample of clean value `clean` after add_sensor_noise: the noise rounded to
// whole DN (the int8 it is drawn into), then the sum saturated, so dark and bright samples hold less.
inline double noise_entropy_bits(int clean, double noise) {
  const auto below = [noise](double x) { return 0.5 * std::erfc(-x / (noise * std::sqrt(2.0))); };
  std::array<double, 256> p{};
  for (int k = -128; k <= 127; ++k) {
    const double lo = k == -128 ? 0.0 : below(k - 0.5), hi = k == 127 ? 1.0 : below(k + 0.5);
    p[std::clamp(clean + k, 0, 255)] += hi - lo;
  }
  double bits = 0;
  for (const double q : p)
    if (q > 0) bits -= q * std::log2(q);
  return bits;
}

// The least any lossless coder can spend, on average, on a frame made by add_sensor_noise from
// `clean`: the noise's entropy given the clean frame. The noise is independent of the scene, of the
// other samples and of the other frames, so no prediction, within a frame or between frames, takes
// any of it away (H(noisy) >= H(noisy | clean)). In bytes.
inline double noise_bound_bytes(const cv::Mat& clean, double noise) {
  std::array<double, 256> bits{};
  for (int v = 0; v < 256; ++v) bits[v] = noise_entropy_bits(v, noise);
  double total = 0;
  for (int r = 0; r < clean.rows; ++r) {
    const std::uint8_t* row = clean.ptr<std::uint8_t>(r);
    for (int c = 0; c < clean.cols * clean.channels(); ++c) total += bits[row[c]];
  }
  return total / 8;
}

}  // namespace pvcap::bench
