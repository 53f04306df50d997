// Warp and crop reproduce PressureVision's definitions on small cases computed by hand.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "calib/projection.h"
#include "sim/camera_views.h"

using namespace pvcap;
using namespace pvcap::calib;

TEST(Projection, WarpIsBilinearPressureWithZerosOffThePad) {
  cv::Mat p(105, 185, CV_32F, cv::Scalar(0));
  p.at<float>(3, 2) = 10.0f;  // row 3, column 2
  const cv::Matx33d twice(2, 0, 0, 0, 2, 0, 0, 0, 1);
  const cv::Mat w = warp_pressure(p, twice, {400, 220});
  EXPECT_FLOAT_EQ(w.at<float>(6, 4), 10.0f);  // image (4, 6) <- cell (2, 3)
  EXPECT_FLOAT_EQ(w.at<float>(6, 5), 5.0f);   // halfway to cell (3, 3): bilinear
  EXPECT_FLOAT_EQ(w.at<float>(7, 5), 2.5f);
  EXPECT_FLOAT_EQ(w.at<float>(6, 7), 0.0f);
  EXPECT_FLOAT_EQ(w.at<float>(215, 395), 0.0f);  // beyond the pad
}

TEST(Projection, PixelAreaAndTheForceConservingWarp) {
  const PadLayout pad = default_pad_layout();
  const cv::Matx33d twice(2, 0, 0, 0, 2, 0, 0, 0, 1);
  const cv::Mat area = pixel_area_mm2(twice, {400, 220}, pad);
  // Each image pixel is a quarter of a 1.25 mm cell.
  EXPECT_NEAR(area.at<float>(50, 50), 0.25 * 1.5625, 1e-6);
  EXPECT_EQ(area.at<float>(215, 390), 0.0f) << "off the pad";
  // 10 kPa on the whole pad: 10e3 Pa * 185 * 105 * 1.5625e-6 m^2 = 303.515625 N.
  const cv::Mat uniform(105, 185, CV_32F, cv::Scalar(10));
  EXPECT_NEAR(sensor_force_n(uniform, pad), 303.515625, 1e-6);
  // An image that holds the whole pad (its half-cell rim included) holds the sensor's force.
  const cv::Matx33d inside(2, 0, 10, 0, 2, 10, 0, 0, 1);
  const cv::Mat conserved = warp_pressure_conserving(uniform, inside, {400, 230}, pad);
  EXPECT_NEAR(cv::sum(conserved.mul(pixel_area_mm2(inside, {400, 230}, pad)))[0] * 1e-3, 303.515625, 1e-3);
  // A perspective homography: area still sums to the pad's area (231.25 x 131.25 mm).
  const cv::Matx33d oblique(3.0, 0.4, 100, 0.1, 2.5, 80, 0.0004, 0.0009, 1);
  EXPECT_NEAR(cv::sum(pixel_area_mm2(oblique, {1200, 700}, pad))[0], 231.25 * 131.25, 231.25 * 131.25 * 0.01);
}

// A crop that cuts the pad (and a contact) in half holds the full image's pressure over the same
// pixels, and the force inside it, not the pad's: warping then cropping equals cropping then warping.
// (Before, the crop's pixels were scaled up to carry the whole sensor's force: 2.10x here.)
TEST(Projection, ACropOfThePadHoldsTheFullImagesPressureAndOnlyTheForceInsideIt) {
  const PadLayout pad = default_pad_layout();
  const cv::Matx33d oblique(3.0, 0.4, 100, 0.1, 2.5, 80, 0.0004, 0.0009, 1);
  const cv::Size full_size(1200, 700);
  cv::Mat p(pad.rows, pad.cols, CV_32F, cv::Scalar(0));
  cv::circle(p, {92, 52}, 9, cv::Scalar(40), cv::FILLED);  // a contact the crop cuts through its middle
  cv::circle(p, {30, 20}, 5, cv::Scalar(25), cv::FILLED);  // and one wholly inside the crop
  cv::GaussianBlur(p, p, {0, 0}, 2.0);
  std::vector<cv::Point2d> centre;
  cv::perspectiveTransform(std::vector<cv::Point2d>{{92, 52}}, centre, oblique);
  const cv::Rect box(0, 0, int(centre[0].x), full_size.height);  // the left part of the pad, to the contact's middle

  const ConservingWarp whole(oblique, full_size, pad);
  double sensor_n = 0;
  const cv::Mat full = whole(p, &sensor_n);
  EXPECT_NEAR(whole.force_in_image_n(full), sensor_n, sensor_n * 1e-4) << "the full image holds the whole pad";

  const cv::Matx33d to_box = cv::Matx33d(1, 0, -box.x, 0, 1, -box.y, 0, 0, 1) * oblique;
  const ConservingWarp cropped(to_box, box.size(), pad);
  double crop_sensor_n = 0;
  const cv::Mat crop = cropped(p, &crop_sensor_n);
  EXPECT_DOUBLE_EQ(crop_sensor_n, sensor_n) << "the sensor's force is the sensor's, whatever the image";

  // Pixel for pixel, within the fixed-point map's rounding (1/32 cell) of a shifted homography.
  const cv::Mat same_pixels = full(box);
  double peak = 0;
  cv::minMaxLoc(full, nullptr, &peak);
  EXPECT_LT(cv::norm(crop, same_pixels, cv::NORM_INF), 0.01 * peak);
  const double crop_sum = cv::sum(crop)[0], full_sum = cv::sum(same_pixels)[0];
  EXPECT_NEAR(crop_sum / full_sum, 1.0, 1e-3) << "a crop inflated its pressure " << crop_sum / full_sum << "x";

  // The force it reports is the force inside it: the full image's over the same pixels, well short of the pad's.
  const cv::Mat full_area = pixel_area_mm2(oblique, full_size, pad);
  const double inside_n = same_pixels.dot(full_area(box)) * 1e-3;
  EXPECT_NEAR(cropped.force_in_image_n(crop), inside_n, inside_n * 1e-3);
  EXPECT_LT(inside_n, 0.8 * sensor_n);
  EXPECT_GT(inside_n, 0.2 * sensor_n);
}

// Where pixels are small against cells, every interior cell reaches exactly its own area.
TEST(Projection, ACellsReachIsItsAreaWhenPixelsAreFine) {
  const PadLayout pad = default_pad_layout();
  const cv::Mat reach = cell_reach_mm2(cv::Matx33d(2, 0, 0, 0, 2, 0, 0, 0, 1), pad);
  EXPECT_NEAR(reach.at<double>(50, 90), pad.pitch_mm * pad.pitch_mm, 1e-9);
  EXPECT_NEAR(reach.at<double>(1, 1), pad.pitch_mm * pad.pitch_mm, 1e-9);
  // A pad blown up past the numeric footprint's bound takes the limit: the cell's own area.
  const cv::Mat huge = cell_reach_mm2(cv::Matx33d(400, 0, 0, 0, 400, 0, 0, 0, 1), pad);
  EXPECT_DOUBLE_EQ(huge.at<double>(0, 0), pad.pitch_mm * pad.pitch_mm);
}

TEST(Projection, PaperCropMatchesTheOriginalsArithmetic) {
  // Corners spanning x 100..300, y 100..200: with a 50 px margin x 50..350, y 50..250; centre
  // (200, 150); half-spans 150 and 100; 150 * 384 / 480 = 120 > 100, so y grows to 120.
  const std::array<cv::Point2d, 4> corners = {{{100, 100}, {300, 100}, {300, 200}, {100, 200}}};
  EXPECT_EQ(paper_crop_box(corners, {1920, 1080}), cv::Rect(50, 30, 300, 240));
  // Taller than wide: x grows instead. y 50..450 -> half-span 200 -> x half-span 250 about 200.
  const std::array<cv::Point2d, 4> tall = {{{150, 100}, {250, 100}, {250, 400}, {150, 400}}};
  EXPECT_EQ(paper_crop_box(tall, {1920, 1080}), cv::Rect(0, 50, 450, 400)) << "clamped at the left edge, as the "
                                                                              "original does";
  // Fractions: the centre rounds half to even, the edges truncate toward zero.
  const std::array<cv::Point2d, 4> frac = {{{100.25, 100}, {300.75, 100}, {300.75, 200}, {100.25, 200}}};
  // x 50.25..350.75: centre round(200.5) = 200; half-span 150.25 -> x0 = int(49.75) = 49, x1 = int(350.25) = 350;
  // y half-span max(100, 150.25 * 0.8 = 120.2): y0 = int(29.8) = 29, y1 = int(270.2) = 270.
  EXPECT_EQ(paper_crop_box(frac, {1920, 1080}), cv::Rect(49, 29, 301, 241));
  const cv::Mat img(1080, 1920, CV_8UC3, cv::Scalar(1, 2, 3));
  EXPECT_EQ(apply_crop(img, paper_crop_box(corners, img.size())).size(), cv::Size(480, 384));
}

// The distorted-image projector puts a pressed cell where the camera model images the pad point.
TEST(Projection, ProjectorFollowsTheLens) {
  const PadLayout pad = default_pad_layout();
  const cv::Size size(960, 540);
  const CameraModel m = sim::sim_camera_model(1, sim::SimCameraClock{}, size, size);
  cv::Mat p(105, 185, CV_32F, cv::Scalar(0));
  cv::circle(p, {20, 90}, 4, cv::Scalar(50), cv::FILLED);  // a press near a corner, where the lens bends most
  const cv::Mat img = PressureProjector(m, pad).project(p);
  cv::Moments mo = cv::moments(img);
  const cv::Point2d centroid(mo.m10 / mo.m00, mo.m01 / mo.m00);
  const cv::Point2d want = m.project({20 * pad.pitch_mm, 90 * pad.pitch_mm, 0});
  EXPECT_LT(cv::norm(centroid - want), 0.5) << centroid << " vs " << want;
}

// project() resamples only the pad's footprint. The whole pad pressed at once must stay strictly
// inside it (a footprint cut too tight shows as pressure reaching its edge), unless both meet the
// image's own edge.
TEST(Projection, ThePadsFootprintHoldsEveryPixelItsPressureReaches) {
  const PadLayout pad = default_pad_layout();
  const cv::Size size(960, 540);
  const cv::Mat ones(pad.rows, pad.cols, CV_32F, cv::Scalar(1));
  for (int camera = 0; camera < 4; ++camera) {
    const CameraModel m = sim::sim_camera_model(camera, sim::SimCameraClock{}, size, size);
    const PressureProjector whole(m, pad);
    for (const PressureProjector& pp : {whole, whole.scaled({640, 360})}) {
      const cv::Mat img = pp.project(ones);
      const cv::Rect f = pp.footprint(), reached = cv::boundingRect(img > 0);
      ASSERT_FALSE(reached.empty()) << "camera " << camera;
      EXPECT_LT(f.area(), img.size().area()) << "camera " << camera << ": the pad fills only part of the view";
      EXPECT_TRUE(reached.x > f.x || reached.x == 0) << camera << ": " << reached << " in " << f;
      EXPECT_TRUE(reached.y > f.y || reached.y == 0) << camera << ": " << reached << " in " << f;
      EXPECT_TRUE(reached.br().x < f.br().x || reached.br().x == img.cols) << camera << ": " << reached << " in " << f;
      EXPECT_TRUE(reached.br().y < f.br().y || reached.br().y == img.rows) << camera << ": " << reached << " in " << f;
    }
  }
}

// What the replay draws: the footprint's part of project(), resampled alone (no full view zeroed),
// the same to the bit, for the full-size projector and a scaled view's fixed-point one.
TEST(Projection, TheFootprintAloneIsProjectOverTheFootprint) {
  const PadLayout pad = default_pad_layout();
  const cv::Size size(960, 540);
  cv::Mat p(pad.rows, pad.cols, CV_32F, cv::Scalar(0));
  cv::circle(p, {40, 30}, 6, cv::Scalar(80), cv::FILLED);
  cv::circle(p, {150, 80}, 3, cv::Scalar(20), cv::FILLED);
  const CameraModel m = sim::sim_camera_model(2, sim::SimCameraClock{}, size, size);
  const PressureProjector whole(m, pad);
  for (const PressureProjector& pp : {whole, whole.scaled({640, 360})}) {
    const cv::Mat part = pp.project_footprint(p);
    ASSERT_EQ(part.size(), pp.footprint().size());
    ASSERT_GT(cv::countNonZero(part), 0);
    EXPECT_EQ(cv::norm(part, pp.project(p)(pp.footprint()), cv::NORM_INF), 0.0);
  }
}

// The colour table built once gives OpenCV's own inferno, every level.
TEST(Projection, InfernoIsOpenCvsColormap) {
  cv::Mat level(16, 16, CV_8U);
  for (int i = 0; i < 256; ++i) level.at<uchar>(i / 16, i % 16) = uchar(i);
  cv::Mat want;
  cv::applyColorMap(level, want, cv::COLORMAP_INFERNO);
  const cv::Mat got = inferno(level);
  ASSERT_EQ(got.type(), CV_8UC3);
  EXPECT_EQ(cv::norm(got, want, cv::NORM_INF), 0.0);
  EXPECT_NE(cv::norm(got.row(0).col(0), got.row(15).col(15), cv::NORM_INF), 0.0);  // not one colour
}
