// The pad's pose and homography measured from simulated camera images (1080p, the sensor's
// mosaic debayered as the capture path does), against the simulator's ground-truth model.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <fstream>

#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/camera_model.h"
#include "calib/pad_calibration.h"
#include "calib/rig_calibration.h"
#include "codec/pixel_format.h"
#include "sim/camera_views.h"
#include "sim/scene.h"

using namespace pvcap;
using namespace pvcap::calib;

namespace {
const cv::Size k1080p(1920, 1080);

CameraModel truth(int camera) { return sim::sim_camera_model(camera, sim::SimCameraClock{}, k1080p, k1080p); }

// What the store gives back for camera `camera`: the scene as its Bayer sensor sends it, debayered.
cv::Mat camera_image(int camera) {
  const cv::Mat bgr = sim::render_scene_bgr(default_pad_layout(), truth(camera));
  const cv::Mat mosaic = sim::to_sensor_format(bgr, "BayerRG8");
  cv::Mat out;
  EXPECT_TRUE(to_bgr(mosaic.data, mosaic.total(), mosaic.cols, mosaic.rows, pvcap::pfnc::kBayerRG8, out).ok());
  return out;
}

// The intrinsics alone (no pose), as an intrinsics calibration hands them over.
CameraModel intrinsics_of(const CameraModel& m) {
  CameraModel i;
  i.image_size = m.image_size;
  i.K = m.K;
  i.distortion = m.distortion;
  return i;
}
}  // namespace

TEST(CameraModel, LooksAtItsTargetAndItsHomographyAgreesWithProjection) {
  const CameraModel m =
      CameraModel::looking_at(k1080p, 1500, {960, 540}, {}, pad_point(100, 50, 400), pad_point(100, 50, 0));
  const cv::Point2d c = m.project({100, 50, 0});
  EXPECT_NEAR(c.x, 960, 1e-9);
  EXPECT_NEAR(c.y, 540, 1e-9);
  // From above, image x follows pad x and image y follows pad y (the pressure image's orientation).
  EXPECT_GT(m.project({110, 50, 0}).x, 960);
  EXPECT_GT(m.project({100, 60, 0}).y, 540);
  // 10 mm at 400 mm with f = 1500 px is 37.5 px.
  EXPECT_NEAR(m.project({110, 50, 0}).x - 960, 37.5, 1e-9);
  const cv::Matx33d h = m.pad_to_ideal();
  const cv::Vec3d p = h * cv::Vec3d(30, 70, 1);
  EXPECT_NEAR(p[0] / p[2], m.project_ideal({30, 70, 0}).x, 1e-9);
  EXPECT_NEAR(p[1] / p[2], m.project_ideal({30, 70, 0}).y, 1e-9);
}

TEST(CameraModel, InterpolatedRaysMatchExactUndistortion) {
  const CameraModel m = truth(2);
  const cv::Mat rays = m.normalised_rays();
  cv::RNG rng(3);
  for (int k = 0; k < 200; ++k) {
    const cv::Point2d px(rng.uniform(0, k1080p.width), rng.uniform(0, k1080p.height));
    const cv::Point2d ideal = m.undistort({px})[0];
    const cv::Vec2f r = rays.at<cv::Vec2f>(int(px.y), int(px.x));
    EXPECT_NEAR(r[0] * m.K(0, 0) + m.K(0, 2), ideal.x, 1e-3) << px;
    EXPECT_NEAR(r[1] * m.K(1, 1) + m.K(1, 2), ideal.y, 1e-3) << px;
  }
}

TEST(CameraModel, JsonRoundTrip) {
  const CameraModel m = truth(1);
  const CameraModel back = nlohmann::json(m).get<CameraModel>();
  EXPECT_EQ(back.image_size, m.image_size);
  EXPECT_EQ(back.distortion, m.distortion);
  EXPECT_LT(cv::norm(back.K - m.K), 1e-12);
  EXPECT_LT(cv::norm(back.R - m.R), 1e-12);
  EXPECT_LT(cv::norm(back.t - m.t), 1e-12);
}

TEST(PadLayout, GridCornersAreTheCellEdgesAroundCellCentres) {
  const PadLayout pad = default_pad_layout();
  const auto c = pad.grid_corners_mm();
  EXPECT_DOUBLE_EQ(c[0].x, -0.625);
  EXPECT_DOUBLE_EQ(c[2].x, 184.5 * 1.25);
  EXPECT_DOUBLE_EQ(c[2].y, 104.5 * 1.25);
  EXPECT_EQ(pad.cell_to_mm({184, 104}), cv::Point2d(230.0, 130.0));
}

// Every default camera: pad corners within 0.3 px median and 1 px max of the truth.
TEST(PadCalibration, PadCornersMatchTheSimulatorsTruthInEveryCamera) {
  const PadLayout pad = default_pad_layout();
  for (int cam = 0; cam < 4; ++cam) {
    SCOPED_TRACE("camera " + std::to_string(cam));
    const CameraModel t = truth(cam);
    const auto markers = detect_pad_markers(camera_image(cam), pad);
    EXPECT_EQ(markers.size(), pad.markers.size());
    auto cal = calibrate_pad(markers, intrinsics_of(t), pad);
    ASSERT_TRUE(cal) << cal.error().message;
    const auto want = pad_corners_px(t, pad);
    std::vector<double> errors;
    for (std::size_t k = 0; k < 4; ++k) errors.push_back(cv::norm(cal.value().pad_corners_px[k] - want[k]));
    std::sort(errors.begin(), errors.end());
    EXPECT_LE((errors[1] + errors[2]) / 2, 0.3);
    EXPECT_LE(errors[3], 1.0);
    EXPECT_LT(cal.value().rms_px, 0.6);
    EXPECT_LT(cal.value().rms_mm, 0.3);
    // The homography maps a cell centre where the model projects it (ideal pixels).
    const cv::Vec3d p = cal.value().cells_to_ideal * cv::Vec3d(92, 52, 1);
    const cv::Point2d q = t.project_ideal({92 * 1.25, 52 * 1.25, 0});
    EXPECT_NEAR(p[0] / p[2], q.x, 0.5);
    EXPECT_NEAR(p[1] / p[2], q.y, 0.5);
  }
}

// A hand over 40 % of the markers: still calibrated from the rest. With all but two hidden, the
// message says how many were seen and what to check.
TEST(PadCalibration, HiddenMarkersAreToleratedOrExplained) {
  const PadLayout pad = default_pad_layout();
  const CameraModel t = truth(3);
  cv::Mat image = camera_image(3);
  auto cover = [&](int id) {
    const cv::Point2d c = t.project({pad.marker(id)->centre_mm.x, pad.marker(id)->centre_mm.y, 0.0});
    cv::circle(image, c, 60, cv::Scalar(110, 140, 205), cv::FILLED);  // skin
  };
  for (int id : {0, 1, 2, 9}) cover(id);
  auto markers = detect_pad_markers(image, pad);
  EXPECT_EQ(markers.size(), 6u);
  auto cal = calibrate_pad(markers, intrinsics_of(t), pad);
  ASSERT_TRUE(cal) << cal.error().message;
  const auto want = pad_corners_px(t, pad);
  for (std::size_t k = 0; k < 4; ++k) EXPECT_LT(cv::norm(cal.value().pad_corners_px[k] - want[k]), 1.0) << k;

  for (int id : {3, 4, 5, 6}) cover(id);
  markers = detect_pad_markers(image, pad);
  auto refused = calibrate_pad(markers, intrinsics_of(t), pad);
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message.find("only 2 of the mat's 10 markers are visible (seen: 7, 8)"), std::string::npos)
      << refused.error().message;
}

TEST(RigCalibrationFile, RoundTripsAndNamesTheFileInEveryError) {
  RigCalibration cal;
  cal.rig = "lab-rig";
  CameraCalibration c;
  c.name = "cam0";
  c.serial = "S1";
  c.model = truth(0);
  c.intrinsics = MeasuredBy{"charuco_intrinsics", "/data/s1", 5, 0.14, std::nullopt, {{"views", 40}}};
  c.pad = MeasuredBy{"pad_markers", "/data/s2", 6, 0.3, 0.1, {{"markers", {0, 1, 2}}}};
  c.cells_to_ideal = cells_to_ideal(c.model, cal.pad);
  c.pad_corners_px = pad_corners_px(c.model, cal.pad);
  cal.cameras.push_back(c);
  const auto dir = std::filesystem::temp_directory_path() / ("pvcap-calfile-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto file = dir / "rig.calibration.yaml";
  ASSERT_TRUE(save_rig_calibration(file, cal).ok());
  auto back = load_rig_calibration(file);
  ASSERT_TRUE(back) << back.error().message;
  ASSERT_EQ(back.value().cameras.size(), 1u);
  const auto& b = back.value().cameras[0];
  EXPECT_EQ(b.name, "cam0");
  EXPECT_LT(cv::norm(b.model.K - c.model.K), 1e-9);
  EXPECT_LT(cv::norm(b.model.t - c.model.t), 1e-9);
  EXPECT_EQ(b.intrinsics->details.at("views").get<int>(), 40);
  EXPECT_DOUBLE_EQ(*b.pad->rms_mm, 0.1);
  EXPECT_LT(cv::norm((*b.pad_corners_px)[2] - (*c.pad_corners_px)[2]), 1e-9);
  EXPECT_EQ(back.value().pad.markers.size(), 10u);

  std::ofstream(file) << "pvcap_calibration: 1\nrig: x\npad_layout: {name: a}\ncameras: []\n";
  auto bad = load_rig_calibration(file);
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().message.rfind(file.string() + ": not a usable calibration file:", 0), 0u)
      << bad.error().message;
  std::ofstream(file) << "rig: x\n";
  bad = load_rig_calibration(file);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("not a pvcap calibration file"), std::string::npos) << bad.error().message;
  std::filesystem::remove_all(dir);
}
