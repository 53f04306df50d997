// Intrinsics from the simulated board session's views, against the simulator's lenses.
#include <gtest/gtest.h>


#include <limits>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "calib/charuco.h"
#include "codec/pixel_format.h"
#include "sim/board_motion.h"
#include "sim/camera_views.h"
#include "sim/scene.h"

using namespace pvcap;
using namespace pvcap::calib;

namespace {
const cv::Size kImageSize(1920, 1080);
}

TEST(Charuco, BoardViewsOfTheSimulatedRigRecoverEachLens) {
  const BoardSpec spec;
  const sim::PlaneTexture board{[&] {
                                  cv::Mat bgr;
                                  cv::cvtColor(board_image(spec, 6.0), bgr, cv::COLOR_GRAY2BGR);
                                  return bgr;
                                }(),
                                cv::Matx33d(6.0, 0, -0.5, 0, 6.0, -0.5, 0, 0, 1)};
  for (int cam : {0, 1, 2, 3}) {
    SCOPED_TRACE("camera " + std::to_string(cam));
    const CameraModel truth = sim::sim_camera_model(cam, sim::SimCameraClock{}, kImageSize, kImageSize);
    const cv::Mat rays = truth.normalised_rays();
    const cv::Mat scene = sim::render_scene_bgr(default_pad_layout(), truth, rays);
    std::vector<BoardView> views;
    for (int i = 0; i < sim::kBoardPoses; ++i) {
      const sim::BoardPose p = sim::board_pose(i, spec.width_mm(), spec.height_mm());
      cv::Mat img = scene.clone();
      sim::draw_plane(img, rays, truth.R * p.R, truth.R * p.t + truth.t, board);
      const cv::Mat mosaic = sim::to_sensor_format(img, "BayerRG8");
      cv::Mat seen;
      ASSERT_TRUE(
          to_bgr(mosaic.data, mosaic.total(), mosaic.cols, mosaic.rows, pvcap::pfnc::kBayerRG8, seen).ok());
      views.push_back(detect_board(seen, spec));
    }
    auto got = calibrate_intrinsics(views, kImageSize, spec);
    ASSERT_TRUE(got) << got.error().message;
    const Intrinsics& in = got.value();
    std::string empty;
    for (auto& e : in.empty_regions) empty += e + "; ";
    std::printf(
        "camera %d: %d views, %d corners, rms %.3f px, fx %.2f (truth %.2f), cx %.2f (%.2f), cy %.2f (%.2f), "
        "sd cx %.2f cy %.2f, empty: %s\n",
        cam, in.views, in.corners, in.rms_px, in.model.K(0, 0), truth.K(0, 0), in.model.K(0, 2), truth.K(0, 2),
        in.model.K(1, 2), truth.K(1, 2), in.deviation[2], in.deviation[3], empty.c_str());
    EXPECT_NEAR(in.model.K(0, 0) / truth.K(0, 0), 1.0, 0.005);
    EXPECT_NEAR(in.model.K(1, 1) / truth.K(1, 1), 1.0, 0.005);
    EXPECT_NEAR(in.model.K(0, 2), truth.K(0, 2), 2.0);
    EXPECT_NEAR(in.model.K(1, 2), truth.K(1, 2), 2.0);
    EXPECT_LT(in.rms_px, 0.5);
    if (cam == 0) {
      // A view with a corner that is not a number (not found where it was looked for) is left out:
      // the same lens as without it, never a fit of NaN.
      std::vector<BoardView> with_nan = views;
      BoardView bad = views[1];
      ASSERT_FALSE(bad.corners.empty());
      bad.corners[0].x = std::numeric_limits<float>::quiet_NaN();
      with_nan.push_back(bad);
      auto again = calibrate_intrinsics(with_nan, kImageSize, spec);
      ASSERT_TRUE(again) << again.error().message;
      EXPECT_EQ(again.value().views, in.views);
      EXPECT_EQ(cv::norm(cv::Mat(again.value().model.K), cv::Mat(in.model.K), cv::NORM_INF), 0.0);
    }
  }
}

TEST(Charuco, TooFewViewsAreRefusedWithWhatToDo) {
  auto got = calibrate_intrinsics({BoardView{}, BoardView{}}, kImageSize, BoardSpec{});
  ASSERT_FALSE(got);
  EXPECT_NE(got.error().message.find("in only 0 frames; at least 8 are needed"), std::string::npos)
      << got.error().message;
}

TEST(Charuco, ThePrintablePdfIsOnePageAtTheBoardsTrueSize) {
  const BoardSpec spec;
  const std::string pdf = board_pdf(spec);
  EXPECT_EQ(pdf.rfind("%PDF-1.4", 0), 0u);
  EXPECT_NE(pdf.find("/Count 1"), std::string::npos);
  // The image is drawn width_mm x height_mm in points (72 per inch).
  EXPECT_NE(pdf.find(fmt::format("q {:.3f} 0 0 {:.3f}", spec.width_mm() * 72 / 25.4, spec.height_mm() * 72 / 25.4)),
            std::string::npos);
  EXPECT_NE(pdf.find("%%EOF"), std::string::npos);
}
