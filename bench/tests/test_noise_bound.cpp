// The least a lossless store can spend on a noisy frame (issue: performance, lossless bytes): the
// entropy of the benches' sensor noise given the clean picture, which docs/performance-log.md gives
// as the floor under every lossless coder on the store bench's noisy mosaics.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>

#include <opencv2/core.hpp>

#include "bench/bench_mosaics.h"

using namespace pvcap;
using bench::kSensorNoiseDn;

namespace {

// The entropy of a frame's samples as counted (the plug-in estimate), in bits per sample.
double counted_entropy_bits(const cv::Mat& frame) {
  std::array<double, 256> count{};
  for (int r = 0; r < frame.rows; ++r)
    for (int c = 0; c < frame.cols; ++c) ++count[frame.at<std::uint8_t>(r, c)];
  double bits = 0;
  for (const double n : count)
    if (n > 0) bits -= n / double(frame.total()) * std::log2(n / double(frame.total()));
  return bits;
}

}  // namespace

TEST(NoiseBound, EachSamplesEntropyIsWhatTheBenchesNoiseGives) {
  // The benches' noise (2 DN). Mid-grey holds the whole rounded Gaussian: about 0.5 log2(2 pi e
  // sigma^2), 3.05 bits at 2 DN
  // (3.06: rounding to whole DN adds a little).
  EXPECT_NEAR(bench::noise_entropy_bits(128, kSensorNoiseDn),
              0.5 * std::log2(2 * M_PI * M_E * kSensorNoiseDn * kSensorNoiseDn), 0.02);
  // Against the noise itself, a million samples per level: black and white saturate half the
  // noise away, so they hold less than mid-grey, and a level near black a little less.
  cv::RNG rng(7);
  for (const int level : {0, 1, 3, 60, 128, 250, 255}) {
    cv::Mat frame(1000, 1000, CV_8UC1, cv::Scalar(level));
    bench::add_sensor_noise(frame, rng, kSensorNoiseDn);
    EXPECT_NEAR(counted_entropy_bits(frame), bench::noise_entropy_bits(level, kSensorNoiseDn), 0.005)
        << "level " << level;
  }
  EXPECT_LT(bench::noise_entropy_bits(0, kSensorNoiseDn), bench::noise_entropy_bits(1, kSensorNoiseDn));
  EXPECT_LT(bench::noise_entropy_bits(1, kSensorNoiseDn), bench::noise_entropy_bits(128, kSensorNoiseDn) - 0.1);
  EXPECT_NEAR(bench::noise_entropy_bits(0, kSensorNoiseDn), bench::noise_entropy_bits(255, kSensorNoiseDn), 1e-9);
  EXPECT_NEAR(bench::noise_entropy_bits(10, kSensorNoiseDn), bench::noise_entropy_bits(128, kSensorNoiseDn),
              1e-3);  // 5 sigma from 0
}

TEST(NoiseBound, TheStoreBenchsNoisyMosaicsHoldMoreThanThePerformanceIssuesGoal) {
  // Two frames of the store bench's camera 0 (its fingertip moves; the rest is the scene): what a
  // lossless coder must average on them, however it predicts. The performance issue asked for
  // 0.75 MB per noisy 1080p frame; the densest coder measured reaches 0.93 (docs/performance-log.md).
  double bound = 0;
  for (const cv::Mat& clean : bench::make_mosaics(0, 2, 0)) {
    ASSERT_EQ(clean.total(), std::size_t(bench::kMosaicWidth) * bench::kMosaicHeight);
    bound += bench::noise_bound_bytes(clean, kSensorNoiseDn) / 2;
  }
  std::printf("the noise's own entropy given the clean mosaics: %.3f MB per frame\n", bound / 1e6);
  EXPECT_GT(bound, 0.75e6);
  // And never above what the noise holds on mid-grey samples.
  EXPECT_LE(bound, bench::noise_entropy_bits(128, kSensorNoiseDn) * bench::kMosaicWidth * bench::kMosaicHeight / 8);
}
