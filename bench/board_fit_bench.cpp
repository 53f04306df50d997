// The lens fit over many board sessions, without recording each: every camera's frame of each
// board hold of the simulated rig is rendered once (exactly as the fake camera sends it: a hold
// renders the same in every frame), demosaiced and searched as `pvcap calibrate intrinsics` does,
// and then board sessions are drawn by seed (how many seconds the start lost, how long it ran,
// where each camera's frames fell) and every camera fitted from the holds its samples show.
//
//   build/bench/board_fit_bench [--sessions N] [--seed S] [--duration SECONDS] [--holds H]
//                               [--views-cache FILE] [--dump-views DIR]
//   build/bench/board_fit_bench --views FILE    (one camera's views, as `pvcap calibrate intrinsics
//                                                --save-views` writes them: fitted and printed)
//
// It prints one line per camera fit outside the targets (focal length 0.5 %, principal point 2 px)
// or failed, and the tally. `--dump-views DIR` writes each failing fit's views as a fixture that
// tests/unit/calib reads (calib/board_views_file.h).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "calib/board_views_file.h"
#include "calib/charuco.h"
#include "codec/pixel_format.h"
#include "core/side_by_side.h"
#include "sim/board_frames.h"
#include "sim/board_motion.h"
#include "sim/camera_views.h"

using namespace pvcap;

namespace {

constexpr int kCameras = 4;
const cv::Size kSize(1920, 1080);

struct Args {
  int sessions = 40, holds = 200, seed = 1;
  double duration_s = 0;  // 0: each session 25 or 40 s, drawn
  std::string cache, dump, views;
};

// views[camera][hold]
using HoldViews = std::vector<std::vector<calib::BoardView>>;

HoldViews render_and_find(int holds) {
  HoldViews out(kCameras, std::vector<calib::BoardView>(std::size_t(holds)));
  const calib::BoardSpec spec;
  for (int c = 0; c < kCameras; ++c) {
    const calib::CameraModel model = sim::sim_camera_model(c, sim::SimCameraClock{}, kSize, kSize);
    sim::BoardFrames frames(model, "BayerRG8", 0);
    run_side_by_side(std::size_t(holds), 2, [&](std::size_t h, std::size_t) {
      const cv::Mat mosaic = frames.render(int(h));
      cv::Mat bgr;
      if (!to_bgr(mosaic.data, mosaic.total(), mosaic.cols, mosaic.rows, pfnc::kBayerRG8, bgr).ok()) std::abort();
      out[std::size_t(c)][h] = calib::detect_board(bgr, spec);
    });
    std::fprintf(stderr, "cam%d: %d holds rendered and searched\n", c, holds);
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // each line as it comes, into a pipe too
  Args a;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--sessions")
      a.sessions = std::atoi(v.c_str());
    else if (k == "--holds")
      a.holds = std::atoi(v.c_str());
    else if (k == "--seed")
      a.seed = std::atoi(v.c_str());
    else if (k == "--duration")
      a.duration_s = std::atof(v.c_str());
    else if (k == "--views-cache")
      a.cache = v;
    else if (k == "--dump-views")
      a.dump = v;
    else if (k == "--views")
      a.views = v;
    else {
      std::fprintf(stderr, "unknown option %s\n", k.c_str());
      return 2;
    }
  }
  if (!a.views.empty()) {
    const auto got = calib::load_board_views(a.views);
    if (!got) {
      std::fprintf(stderr, "%s\n", got.error().message.c_str());
      return 2;
    }
    const auto fit = calib::calibrate_intrinsics(got.value().views, got.value().image_size, calib::BoardSpec{});
    if (!fit) {
      std::printf("%s: %s\n", a.views.c_str(), fit.error().message.c_str());
      return 1;
    }
    const auto& in = fit.value();
    std::printf(
        "%s: %d views (%d left out, %d repeats), %d corners (%d misread), RMS %.3f px; f %.2f cx %.2f cy %.2f\n",
        a.views.c_str(), in.views, in.rejected_views, in.repeated_views, in.corners, in.misread_corners, in.rms_px,
        in.model.K(0, 0), in.model.K(0, 2), in.model.K(1, 2));
    return 0;
  }
  HoldViews views;
  if (!a.cache.empty() && std::filesystem::exists(a.cache)) {
    for (int c = 0; c < kCameras; ++c) {
      auto got = calib::load_board_views(fmt::format("{}.cam{}", a.cache, c));
      if (!got) {
        std::fprintf(stderr, "%s\n", got.error().message.c_str());
        return 2;
      }
      views.push_back(std::move(got.value().views));
    }
    a.holds = int(views[0].size());
  } else {
    views = render_and_find(a.holds);
    if (!a.cache.empty()) {
      for (int c = 0; c < kCameras; ++c)
        (void)calib::save_board_views(fmt::format("{}.cam{}", a.cache, c), {kSize, views[std::size_t(c)]});
      std::ofstream(a.cache) << "holds " << a.holds << "\n";
    }
  }
  if (!a.dump.empty()) std::filesystem::create_directories(a.dump);

  const calib::BoardSpec spec;
  int fits = 0, failed = 0, outside = 0;
  double worst_focal = 0, worst_principal = 0;
  for (int s = 0; s < a.sessions; ++s) {
    std::mt19937 rng(std::uint32_t(a.seed * 7919 + s));
    const double lost = std::uniform_real_distribution<double>(0.0, 6.0)(rng);
    const double duration = a.duration_s > 0 ? a.duration_s : (rng() % 2 ? 40.0 : 25.0);
    for (int c = 0; c < kCameras; ++c) {
      std::vector<calib::BoardView> session_views;
      for (int hold : sim::board_session_holds(rng, lost, duration, a.holds))
        session_views.push_back(views[std::size_t(c)][std::size_t(hold)]);
      const calib::CameraModel truth = sim::sim_camera_model(c, sim::SimCameraClock{}, kSize, kSize);
      const auto got = calib::calibrate_intrinsics(session_views, kSize, spec);
      ++fits;
      std::string what;
      if (!got) {
        ++failed;
        what = got.error().message;
      } else {
        const cv::Matx33d& K = got.value().model.K;
        const double focal = std::abs(K(0, 0) / truth.K(0, 0) - 1);
        const double principal = std::max(std::abs(K(0, 2) - truth.K(0, 2)), std::abs(K(1, 2) - truth.K(1, 2)));
        worst_focal = std::max(worst_focal, focal);
        worst_principal = std::max(worst_principal, principal);
        if (focal > 0.005 || principal > 2.0) {
          ++outside;
          what = fmt::format("outside the targets: focal {:+.3f} %, principal point {:+.2f} / {:+.2f} px",
                             100 * (K(0, 0) / truth.K(0, 0) - 1), K(0, 2) - truth.K(0, 2), K(1, 2) - truth.K(1, 2));
        }
      }
      if (what.empty()) continue;
      std::printf("session %d (lost %.1f s of %.0f s) cam%d: %s\n", s, lost, duration, c, what.c_str());
      if (!a.dump.empty())
        (void)calib::save_board_views(fmt::format("{}/seed{}-session{}-cam{}.yaml", a.dump, a.seed, s, c),
                                      {kSize, session_views});
    }
  }
  std::printf(
      "board fits: %d sessions x %d cameras = %d fits, %d failed, %d outside the targets; worst focal error "
      "%.3f %%, worst principal point error %.2f px (of the fits that succeeded)\n",
      a.sessions, kCameras, fits, failed, outside, 100 * worst_focal, worst_principal);
  return failed + outside == 0 ? 0 : 1;
}
