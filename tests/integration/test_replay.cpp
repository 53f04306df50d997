// `pvcap replay --out` on a short simulated protocol session: the video has a picture per sample of
// the take at the session's own timing, and in each camera's view the pressure overlay's hot pixels
// lie where the simulator's truth put the press, projected through that camera's true lens.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "replay/replay_composer.h"
#include "sim/hand.h"
#include "sim/truth.h"
#include "storage/index/session_reader.h"
#include "storage/video/video_reader.h"
#include "tests/integration/picture_files.h"
#include "tests/integration/session_under_test.h"

namespace fs = std::filesystem;
using pvcap::testing::only_session;
using pvcap::testing::run_pvcap;
using pvcap::testing::sim_rig_yaml;
using pvcap::testing::work_dir;
using pvcap::testing::write_press_protocol;
using pvcap::testing::write_truth_lenses;
using Layout = pvcap::replay::Layout;

TEST(Replay, TheRenderedTakeShowsThePressWhereTheSimulatorPutIt) {
  const fs::path work = work_dir("replay");
  std::ofstream(work / "rig.yaml") << sim_rig_yaml({{}, {}, {}, {}}, 640, 480, 30, 15, "free-run", /*sensel=*/true);
  const auto session_run = run_pvcap(fmt::format(
      "session --rig {} --root {} --protocol {} --auto --fast --participant R02 --skin-tone medium --no-web",
      (work / "rig.yaml").string(), (work / "sessions").string(),
      write_press_protocol(work, "[high]", 0.5, 0.4, 2.0, 0.3).string()));
  ASSERT_EQ(session_run.exit_code, 0) << session_run.output;
  const fs::path session = only_session(work / "sessions");
  // The pad calibrated through the simulator's lenses (no board session needed here).
  ASSERT_EQ(write_truth_lenses(session, work / "lenses.yaml"), "");
  const auto pad =
      run_pvcap(fmt::format("calibrate pad {} --calibration {}", session.string(), (work / "lenses.yaml").string()));
  ASSERT_EQ(pad.exit_code, 0) << pad.output;

  // The first take, rendered.
  auto reader = pvcap::SessionReader::open(session);
  ASSERT_TRUE(reader) << reader.error().message;
  auto& r = *reader.value();
  auto composer = pvcap::replay::ReplayComposer::open(r, session);
  ASSERT_TRUE(composer) << composer.error().message;
  for (std::size_t c = 0; c < 4; ++c) EXPECT_TRUE(composer.value().calibrated(c)) << c;
  const std::string take = "press_index_finger_high_2x_right";
  auto range = composer.value().take_samples(take);
  ASSERT_TRUE(range) << range.error().message;
  const auto [first, end] = range.value();
  ASSERT_GT(end - first, 20u);
  const fs::path out = work / "take.mp4";
  const auto rendered = run_pvcap(fmt::format("replay {} --out {} --take {}", session.string(), out.string(), take));
  ASSERT_EQ(rendered.exit_code, 0) << rendered.output;
  std::printf("%s", rendered.output.c_str());
  EXPECT_NE(rendered.output.find(fmt::format("{} frames", end - first)), std::string::npos) << rendered.output;

  // Frame count and duration: a picture per sample, at the samples' own times.
  auto video = pvcap::VideoReader::open(out);
  ASSERT_TRUE(video) << video.error().message;
  EXPECT_EQ(video.value()->width(), Layout::kWidth);
  EXPECT_EQ(video.value()->height(), Layout::kHeight);
  std::vector<cv::Mat> pictures;
  std::vector<std::int64_t> pts;
  for (;;) {
    cv::Mat picture;
    std::int64_t at = 0;
    auto more = video.value()->next(picture, at);
    ASSERT_TRUE(more) << more.error().message;
    if (!more.value()) break;
    pictures.push_back(picture.clone());
    pts.push_back(at);
  }
  ASSERT_EQ(pictures.size(), end - first);
  const std::int64_t t_first = r.sample_info(first).value().t_ns, t_last = r.sample_info(end - 1).value().t_ns;
  EXPECT_NEAR(double(pts.back() - pts.front()), double(t_last - t_first) / 1e6, 2.0) << "duration in ms";

  // The strongest press of the take, and where the simulated hand was pressing then (the truth).
  std::size_t peak = first;
  double peak_total = -1;
  for (std::size_t i = first; i < end; ++i) {
    auto s = r.sample(i);
    ASSERT_TRUE(s);
    if (!s.value().pressure) continue;
    // A sample with every view (on a loaded machine a group may lack a camera's frame).
    if (std::any_of(s.value().images.begin(), s.value().images.end(), [](const cv::Mat& m) { return m.empty(); }))
      continue;
    const double total = cv::sum(s.value().pressure_image)[0];
    if (total > peak_total) peak_total = total, peak = i;
  }
  ASSERT_GT(peak_total, 0);
  const std::int64_t t_peak = r.sample_info(peak).value().t_ns;
  std::optional<pvcap::sim::HandCommand> press;
  {
    std::ifstream hand(session / "sim-truth" / "hand.csv");
    std::string line;
    while (std::getline(hand, line)) {
      const auto comma = line.find(',');
      if (comma == std::string::npos) continue;
      auto c = pvcap::sim::HandCommand::parse(line.substr(comma + 1));
      if (c && c->from_ns <= t_peak && c->mode == pvcap::sim::HandCommand::Mode::Press) press = c;
    }
  }
  ASSERT_TRUE(press) << "no press command before the peak";
  auto truth = pvcap::sim::read_rig_truth(session / "sim-truth");
  ASSERT_TRUE(truth) << truth.error().message;

  // In each view: the pixels the overlay changed (the rendering against the same image without it,
  // read as the render read it: from the view videos, or with --from-raw from the lossless videos),
  // their centroid against the truth's press projected through the camera's true lens.
  const fs::path out_raw = work / "take-from-raw.mp4";
  const auto rendered_raw =
      run_pvcap(fmt::format("replay {} --out {} --take {} --from-raw", session.string(), out_raw.string(), take));
  ASSERT_EQ(rendered_raw.exit_code, 0) << rendered_raw.output;
  cv::Mat picture_raw;
  {
    auto v = pvcap::VideoReader::open(out_raw);
    ASSERT_TRUE(v) << v.error().message;
    std::int64_t at = 0;
    for (std::size_t k = first; k <= peak; ++k) {
      auto more = v.value()->next(picture_raw, at);
      ASSERT_TRUE(more && more.value()) << "sample " << k;
    }
  }
  r.set_demosaic(pvcap::Demosaic::HalfSize);
  for (const bool from_views : {true, false}) {
    const cv::Mat& picture = from_views ? pictures[peak - first] : picture_raw;
    r.set_view_videos(from_views);
    for (std::size_t c = 0; c < 4; ++c) {
      const auto& cam = r.cameras()[c];
      const cv::Rect fit = Layout::fitted({cam.width, cam.height});
      const cv::Rect where(Layout::view(c).tl() + fit.tl(), fit.size());
      r.set_image_size(fit.size());
      auto image = r.image(peak, c);
      ASSERT_TRUE(image && !image.value().empty()) << c;
      const cv::Mat& plain = image.value();
      ASSERT_EQ(plain.size(), fit.size());
      cv::Mat diff, mask;
      cv::absdiff(picture(where), plain, diff);
      cv::transform(diff, mask, cv::Matx13f(1, 1, 1));
      mask = mask > 90;
      mask(cv::Rect(0, fit.height - 32, fit.width, 32)).setTo(0);  // the camera's name label
      // The largest blob: the video's coding also changes a few pixels along the markers' sharp edges.
      cv::Mat labels, stats, centroids;
      const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids);
      int best = 0;
      for (int k = 1; k < n; ++k)
        if (best == 0 || stats.at<int>(k, cv::CC_STAT_AREA) > stats.at<int>(best, cv::CC_STAT_AREA)) best = k;
      ASSERT_GT(best, 0) << "camera " << c << ": no overlay found";
      const int area = stats.at<int>(best, cv::CC_STAT_AREA);
      ASSERT_GT(area, 20) << "camera " << c << ": no overlay found";
      const cv::Point2d hot(centroids.at<double>(best, 0), centroids.at<double>(best, 1));
      const auto* t = truth.value().camera(cam.name);
      ASSERT_NE(t, nullptr);
      const cv::Point2d px = t->model.project({press->x_mm, press->y_mm, 0.0});
      const double scale = double(fit.width) / cam.width;
      const cv::Point2d expected((px.x + 0.5) * scale - 0.5, (px.y + 0.5) * scale - 0.5);
      const double off = cv::norm(hot - expected);
      std::printf("%s (%s): overlay centre (%.1f, %.1f), truth (%.1f, %.1f): %.2f view px (%d pixels hot)\n",
                  cam.name.c_str(), from_views ? "view videos" : "--from-raw", hot.x, hot.y, expected.x, expected.y,
                  off, area);
      EXPECT_LT(off, 4.0) << cam.name << (from_views ? " (view videos)" : " (--from-raw)");
    }
  }
  // The two renders show the same session: alike, but not the same bytes.
  const double psnr = cv::PSNR(pictures[peak - first], picture_raw);
  std::printf("view videos against --from-raw, the peak's picture: PSNR %.1f dB\n", psnr);
  EXPECT_GT(psnr, 28.0);
  EXPECT_LT(psnr, 99.0) << "--from-raw read the view videos";
  r.set_view_videos(false);
  r.set_image_size({});

  // The window, on Qt's headless display: to the next take, two samples on, quit. What it showed
  // last is that sample's picture, with the status line under it.
  const auto starts = composer.value().take_starts();
  ASSERT_GE(starts.size(), 2u);
  ASSERT_GT(starts.back(), 0u);
  const std::size_t expected = *std::upper_bound(starts.begin(), starts.end(), std::size_t{0}) + 2;
  setenv("QT_QPA_PLATFORM", "offscreen", 1);
  const fs::path shot = work / "window.png";
  const auto window =
      run_pvcap(fmt::format("replay {} --keys n,right,right,q --snapshot {}", session.string(), shot.string()));
  unsetenv("QT_QPA_PLATFORM");
  ASSERT_EQ(window.exit_code, 0) << window.output;
  EXPECT_NE(window.output.find(fmt::format("the last of sample {}", expected)), std::string::npos) << window.output;
  const cv::Mat seen = pvcap::testing::read_picture(shot);
  ASSERT_FALSE(seen.empty());
  ASSERT_GT(seen.rows, Layout::kHeight) << "the status line under the picture";
  auto want = composer.value().compose(expected);
  ASSERT_TRUE(want) << want.error().message;
  EXPECT_EQ(cv::norm(seen(cv::Rect(0, 0, Layout::kWidth, Layout::kHeight)), want.value(), cv::NORM_INF), 0.0);
}
