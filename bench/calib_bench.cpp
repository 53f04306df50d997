// Pad calibration speed: marker detection + pose for one 1080p frame on one core, per simulated
// camera, with a reference measured in the same run (OpenCV's own detectMarkers with default
// parameters, what a naive implementation would call).
//
//   build/bench/calib_bench [iterations]
#include <arv.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>

#include <opencv2/aruco.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/pad_calibration.h"
#include "codec/pixel_format.h"
#include "sim/camera_views.h"
#include "sim/scene.h"

using namespace pvcap;
using Clock = std::chrono::steady_clock;

int main(int argc, char** argv) {
  const int iterations = argc > 1 ? std::atoi(argv[1]) : 20;
  cv::setNumThreads(1);
  const cv::Size size(1920, 1080);
  const calib::PadLayout pad = calib::default_pad_layout();
  std::printf("pad calibration, one 1080p frame, one core, %d iterations per camera\n", iterations);
  double worst_ms = 0;
  for (int cam = 0; cam < 4; ++cam) {
    calib::CameraModel truth = sim::sim_camera_model(cam, sim::SimCameraClock{}, size, size);
    const cv::Mat mosaic = sim::to_sensor_format(sim::render_scene_bgr(pad, truth), "BayerRG8");
    cv::Mat image;
    if (!to_bgr(mosaic.data, mosaic.total(), mosaic.cols, mosaic.rows, ARV_PIXEL_FORMAT_BAYER_RG_8, image).ok())
      return 1;
    calib::CameraModel intrinsics = truth;
    intrinsics.R = cv::Matx33d::eye();
    intrinsics.t = {};

    auto t0 = Clock::now();
    double rms = 0;
    for (int i = 0; i < iterations; ++i) {
      auto cal = calib::calibrate_pad(calib::detect_pad_markers(image, pad), intrinsics, pad);
      if (!cal) return 1;
      rms = cal.value().rms_px;
    }
    const double ours_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count() / iterations;

    cv::Mat grey;
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
    const auto dict = cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_50);
    t0 = Clock::now();
    for (int i = 0; i < iterations; ++i) {
      std::vector<std::vector<cv::Point2f>> corners;
      std::vector<int> ids;
      cv::aruco::detectMarkers(grey, dict, corners, ids);
    }
    const double ref_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count() / iterations;
    worst_ms = std::max(worst_ms, ours_ms);
    std::printf(
        "cam%d: detection + pose %.1f ms (target <= 10 ms), reprojection %.3f px; reference "
        "detectMarkers(defaults) %.1f ms; ratio %.2f\n",
        cam, ours_ms, rms, ref_ms, ours_ms / ref_ms);
  }
  std::printf("worst camera: %.1f ms per frame (%s)\n", worst_ms, worst_ms <= 10.0 ? "within target" : "OVER target");
  return 0;
}
