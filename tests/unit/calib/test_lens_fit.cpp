// The lens fit that stopped the main job one run in three (docs/calibration.md, "Why a fit once left
// the image"): the cause on a failing board session kept as a fixture, and the fit over many board
// sessions drawn by seed from every simulated camera's views of each board hold (the fixtures are
// what `build/bench/board_fit_bench --views-cache F` writes; regenerate them when the simulated
// board or its cameras change).
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>

#include <fmt/format.h>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>

#include "calib/board_coverage.h"
#include "calib/board_views_file.h"
#include "calib/charuco.h"
#include "sim/board_motion.h"
#include "sim/camera_views.h"

using namespace pvcap;
using namespace pvcap::calib;

namespace {

const std::filesystem::path kFixtures = std::filesystem::path(PVCAP_SOURCE_DIR) / "tests/unit/calib/fixtures";

BoardViews load(const std::string& name) {
  auto got = load_board_views(kFixtures / name);
  if (!got) throw std::runtime_error(got.error().message);
  return got.value();
}

CameraModel truth_of(int camera, cv::Size size) {
  return sim::sim_camera_model(camera, sim::SimCameraClock{}, size, size);
}

// The targets: focal length within 0.5 %, principal point within 2 px.
void expect_within_targets(const Intrinsics& in, const CameraModel& truth) {
  EXPECT_NEAR(in.model.K(0, 0) / truth.K(0, 0), 1.0, 0.005);
  EXPECT_NEAR(in.model.K(0, 2), truth.K(0, 2), 2.0);
  EXPECT_NEAR(in.model.K(1, 2), truth.K(1, 2), 2.0);
}

// The rule views passed before: enough corners, over two rows and two columns of the board.
bool old_rule(const BoardView& v, const BoardSpec& spec) {
  std::set<int> rows, cols;
  for (int id : v.ids) rows.insert(id / (spec.squares_x - 1)), cols.insert(id % (spec.squares_x - 1));
  return v.corners.size() >= kMinBoardCorners && rows.size() >= 2 && cols.size() >= 2;
}

}  // namespace

// cam0 of a board session in which the fit failed: two of its views hold one whole row of the board
// and a single corner of the next (the board at the image's edge). They passed the rule of two rows
// and two columns, yet fix no plane (every four of their corners hold three on a line): OpenCV starts
// each view's pose from its homography, arbitrary for these, and the whole fit settles far from the
// lens. The views without them fit it; calibrate_intrinsics leaves them out.
TEST(LensFit, AFailingBoardSessionsCauseIsViewsThatFixNoPlane) {
  const BoardSpec spec;
  const BoardViews fixture = load("failing-board-session.cam0.yaml");
  const CameraModel truth = truth_of(0, fixture.image_size);
  std::vector<std::vector<cv::Point2f>> all_corners, good_corners;
  std::vector<std::vector<int>> all_ids, good_ids;
  int row_and_a_corner = 0;
  for (const BoardView& v : fixture.views) {
    if (!old_rule(v, spec)) continue;
    all_corners.push_back(v.corners), all_ids.push_back(v.ids);
    if (tells_the_plane(v, spec)) {
      good_corners.push_back(v.corners), good_ids.push_back(v.ids);
      continue;
    }
    std::map<int, int> per_row;
    for (int id : v.ids) ++per_row[id / (spec.squares_x - 1)];
    if (per_row.size() == 2 && std::min(per_row.begin()->second, per_row.rbegin()->second) == 1) ++row_and_a_corner;
  }
  EXPECT_GE(row_and_a_corner, 2) << "the fixture holds the views that sent the fit away";
  const auto fit = [&](const auto& corners, const auto& ids) {
    cv::Mat K = cv::Mat::eye(3, 3, CV_64F), dist;
    std::vector<cv::Mat> r, t;
    const double rms = cv::aruco::calibrateCameraCharuco(
        corners, ids, make_board(spec), fixture.image_size, K, dist, r, t,
        cv::CALIB_FIX_ASPECT_RATIO | cv::CALIB_USE_LU,
        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 1e-9));  // far enough to show it
    return std::make_pair(rms, cv::Matx33d(K));
  };
  const auto [rms_all, K_all] = fit(all_corners, all_ids);
  std::printf("with the planeless views: RMS %.2f px, fx %.1f, cx %.1f, cy %.1f (truth %.1f, %.1f, %.1f)\n", rms_all,
              K_all(0, 0), K_all(0, 2), K_all(1, 2), truth.K(0, 0), truth.K(0, 2), truth.K(1, 2));
  EXPECT_GT(rms_all, 5.0) << "the whole fit is pulled away, not one view";
  const auto [rms_good, K_good] = fit(good_corners, good_ids);
  EXPECT_LT(rms_good, 1.0);
  EXPECT_NEAR(K_good(0, 0) / truth.K(0, 0), 1.0, 0.005);

  const auto got = calibrate_intrinsics(fixture.views, fixture.image_size, spec);
  ASSERT_TRUE(got) << got.error().message;
  expect_within_targets(got.value(), truth);
  EXPECT_LT(got.value().rms_px, 0.5);
}

// A corner read at another corner's place is left out of its view, and the view kept.
TEST(LensFit, AMisreadCornerIsLeftOutOfItsView) {
  const BoardSpec spec;
  const BoardViews holds = load("sim-board-holds.cam1.yaml");
  BoardView v;
  for (const BoardView& h : holds.views)
    if (h.corners.size() > v.corners.size()) v = h;
  ASSERT_GE(v.corners.size(), 20u);
  BoardView misread = v;
  std::swap(misread.corners[3], misread.corners[misread.corners.size() - 4]);  // two ids swapped
  EXPECT_EQ(drop_misread_corners(misread, spec), 2);
  EXPECT_EQ(misread.corners.size(), v.corners.size() - 2);
  BoardView clean = v;
  EXPECT_EQ(drop_misread_corners(clean, spec), 0) << "the lens's bending is not a misread";
}

// Every simulated camera fitted within the targets in every board session drawn, 25 s long, with
// up to 6 s lost at the start as on a loaded PC. Before the fix, 3 of 30 such sessions
// failed on cam0 (bench/board_fit_bench; docs/calibration.md).
TEST(LensFit, EveryCameraFitsInBoardSessionsOfTenSeeds) {
  const BoardSpec spec;
  std::vector<BoardViews> holds;
  for (int c = 0; c < 4; ++c) holds.push_back(load(fmt::format("sim-board-holds.cam{}.yaml", c)));
  for (int seed = 1; seed <= 10; ++seed) {
    std::mt19937 rng{std::uint32_t(seed)};
    const double lost = std::uniform_real_distribution<double>(0.0, 6.0)(rng);
    // 25 s, as the demo records: a fit's time grows with the cube of its views (reference BLAS's LU
    // of the whole system at every step), and the 40 s sessions are bench/board_fit_bench's.
    const double duration = 25.0;
    for (int c = 0; c < 4; ++c) {
      SCOPED_TRACE(fmt::format("seed {} ({:.1f} s of {:.0f} s lost), cam{}", seed, lost, duration, c));
      std::vector<BoardView> views;
      for (int hold : sim::board_session_holds(rng, lost, duration, int(holds[std::size_t(c)].views.size())))
        views.push_back(holds[std::size_t(c)].views[std::size_t(hold)]);
      const auto got = calibrate_intrinsics(views, holds[std::size_t(c)].image_size, spec);
      ASSERT_TRUE(got) << got.error().message;
      expect_within_targets(got.value(), truth_of(c, holds[std::size_t(c)].image_size));
    }
  }
}

// Views that cannot fix a lens fail with what they lack: here only boards square to the camera in
// the image's middle, so the message names the empty regions and the missing tilts.
TEST(LensFit, ViewsThatLackTiltsAndRegionsAreToldSo) {
  const BoardSpec spec;
  const cv::Size size(1920, 1080);
  CameraModel cam = truth_of(0, size);
  cam.distortion.clear();
  std::vector<BoardView> views;
  for (int k = 0; k < 12; ++k) {
    BoardView v;
    for (int id = 0; id < (spec.squares_x - 1) * (spec.squares_y - 1); ++id) {
      const cv::Point2f b = board_corner_mm(id, spec);
      // Square to the camera, 600 mm away, moved a little each view: no depth to see a focal length in.
      const cv::Point3d p(b.x - 110 + 3 * k, b.y - 75 + 2 * k, 600);
      v.ids.push_back(id);
      v.corners.emplace_back(float(cam.K(0, 0) * p.x / p.z + cam.K(0, 2)),
                             float(cam.K(1, 1) * p.y / p.z + cam.K(1, 2)));
    }
    views.push_back(v);
  }
  BoardCoverage coverage(size, spec);
  for (const auto& v : views) coverage.add(v);
  const auto missing = coverage.missing(cam.K(0, 0));
  std::string said;
  for (const auto& m : missing) said += m + "\n";
  EXPECT_NE(said.find("corners in the image's top far left (0 of 20)"), std::string::npos) << said;
  EXPECT_NE(said.find("views tilted 15 degrees or more with the board's left edge nearer the camera (0 of 3)"),
            std::string::npos)
      << said;
  // The operator's line: short, the first few places, how many more.
  const std::string line = coverage.summary(cam.K(0, 0));
  EXPECT_NE(line.find("12 views; regions "), std::string::npos) << line;
  EXPECT_NE(line.find("(short: top far left 0/20"), std::string::npos) << line;
  EXPECT_NE(line.find("tilts 0 of 4 (short: top edge nearer 0/3, bottom edge nearer 0/3, left edge nearer 0/3, 1 more)"),
            std::string::npos)
      << line;
  EXPECT_LT(line.size(), 260u) << line;
  // Boards square to the camera at one depth cannot fix a focal length: no lens is given, and the
  // error says what the views lack.
  const auto got = calibrate_intrinsics(views, size, spec);
  ASSERT_FALSE(got) << "a lens fitted to views that cannot fix it: fx " << got.value().model.K(0, 0) << " +- "
                    << got.value().deviation[0];
  EXPECT_NE(got.error().message.find("the views lack corners in the image's top far left"), std::string::npos)
      << got.error().message;
  EXPECT_NE(got.error().message.find("views tilted 15 degrees or more"), std::string::npos) << got.error().message;
}

// The views file round-trips, and a damaged one is one clear error naming the file.
TEST(LensFit, BoardViewsFilesRoundTripAndRefuseDamage) {
  const auto dir = std::filesystem::temp_directory_path() / fmt::format("pvcap-board-views-{}", getpid());
  std::filesystem::create_directories(dir);
  const BoardViews holds = load("sim-board-holds.cam2.yaml");
  ASSERT_TRUE(save_board_views(dir / "v.yaml", holds).ok());
  const auto back = load_board_views(dir / "v.yaml");
  ASSERT_TRUE(back) << back.error().message;
  ASSERT_EQ(back.value().views.size(), holds.views.size());
  EXPECT_EQ(back.value().views[7].ids, holds.views[7].ids);
  {
    std::ofstream(dir / "bad.yaml")
        << "pvcap_board_views: 1\nimage_size: [1920, 1080]\nviews:\n  - {ids: [1, 2], xy: [1]}\n";
  }
  const auto bad = load_board_views(dir / "bad.yaml");
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("bad.yaml: not a board views file: view 0 has 2 ids but 1 coordinates"),
            std::string::npos)
      << bad.error().message;
  std::filesystem::remove_all(dir);
}
