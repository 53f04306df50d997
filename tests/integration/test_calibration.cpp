// Calibration through the pvcap command on the simulated rig (1080p, sensor noise, the store's
// default codec), checked against the simulator's truth by `--ground-truth` itself and here.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <regex>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "calib/board_views_file.h"
#include "calib/rig_calibration.h"
#include "core/time.h"
#include "sim/truth.h"
#include "storage/index/database.h"
#include "storage/index/session_reader.h"
#include "sync/clock_fit.h"
#include "tests/integration/picture_files.h"
#include "tests/integration/session_under_test.h"

namespace fs = std::filesystem;
using pvcap::testing::only_session;
using namespace pvcap::testing;

namespace {
// The repository's simulated rig at full size, copied so its calibration file lands beside it.
fs::path write_full_size_rig(const fs::path& dir) {
  fs::copy_file(fs::path(PVCAP_SOURCE_DIR) / "rig-configs" / "sim.yaml", dir / "rig.yaml");
  return dir / "rig.yaml";
}

// The same rig with its cameras at 15 frames a second, the rate the samples keep (the intrinsics read
// the samples): half the simulator's work. At 30 fps beside another test's rig, the 4 x 1080p
// simulator fell to about 14 fps and one camera was in 71 of 292 samples (CI, 2026-11-27).
fs::path write_full_size_board_rig(const fs::path& dir) {
  std::string rig = read_all(fs::path(PVCAP_SOURCE_DIR) / "rig-configs" / "sim.yaml");
  int replaced = 0;
  for (auto at = rig.find("frame_rate: 30"); at != std::string::npos; at = rig.find("frame_rate: 30", at), ++replaced)
    rig.replace(at, 14, "frame_rate: 15");
  EXPECT_EQ(replaced, 4) << "rig-configs/sim.yaml's four cameras at 30 fps";
  // Without view videos: this test's subject is the lens fit, read from the lossless videos, and on
  // 2 cores the four 1080p view encodes made its session fall behind beside the other lane's tests
  // (2026-11-29; they are tested by SessionStore.ViewVideos... and Replay.TheRenderedTake...).
  const std::string views = "view_videos: true";
  EXPECT_NE(rig.find(views), std::string::npos) << "rig-configs/sim.yaml names store.view_videos";
  if (const auto at = rig.find(views); at != std::string::npos) rig.replace(at, views.size(), "view_videos: false");
  std::ofstream(dir / "rig.yaml") << rig;
  return dir / "rig.yaml";
}

int count(const std::string& text, const std::string& needle) {
  int n = 0;
  for (auto p = text.find(needle); p != std::string::npos; p = text.find(needle, p + 1)) ++n;
  return n;
}

// Printed with the board test's figures, and in its failure's message: how late each camera's frames of its last
// connection reached pvcap after the instant they were taken (arrival minus the final clock fit, which the re-mapping
// found within a fraction of a millisecond of the truth), and how many came after their instant was decided. A camera
// out of most samples whose frames arrived on time was mapped wrong live; one whose frames arrived late was late: then
// the leader packet's lateness (Aravis stamps it on the wall clock) tells a frame the simulator sent late from one
// whose transfer took long.
std::string lateness_by_camera(pvcap::sqlite::Database& db) {
  std::string out;
  auto cameras = db.prepare("SELECT id, name FROM devices WHERE kind = 'camera' ORDER BY name");
  while (cameras.step()) {
    const std::int64_t id = cameras.column_int(0);
    auto fit = db.prepare(
        "SELECT x0_device_ns, offset_ns, skew, latency_ns FROM clock_models WHERE device_id = ? ORDER BY host_ns DESC "
        "LIMIT 1");
    fit.bind_all(id);
    if (!fit.step()) continue;
    const std::int64_t x0 = fit.column_int(0), latency = fit.column_int(3);
    const double offset = fit.column_double(1), skew = fit.column_double(2);
    auto frames = db.prepare(
        "SELECT device_ns, host_ns, aravis_system_ns, reason = 'late_for_its_instant', connection FROM frames WHERE "
        "device_id = ?1 AND connection = (SELECT max(connection) FROM frames WHERE device_id = ?1)");
    frames.bind_all(id);
    const std::int64_t wall_to_host = pvcap::host_now().ns - pvcap::wall_now_ns();
    std::vector<double> late_ms, leader_ms;
    int too_late = 0;
    std::int64_t connection = 0;
    while (frames.step()) {
      const std::int64_t taken = pvcap::sync::map_device_time(frames.column_int(0), x0, offset, skew, latency);
      late_ms.push_back(double(frames.column_int(1) - taken) / 1e6);
      if (frames.column_int(2) > 0) leader_ms.push_back(double(frames.column_int(2) + wall_to_host - taken) / 1e6);
      too_late += int(frames.column_int(3));
      connection = frames.column_int(4);
    }
    if (late_ms.empty()) continue;
    const auto median = [](std::vector<double>& v) {
      std::sort(v.begin(), v.end());
      return v.empty() ? 0.0 : v[v.size() / 2];
    };
    const double late_p50 = median(late_ms), late_p90 = late_ms[late_ms.size() * 9 / 10];
    // Leaders on time and whole frames late put the time in the frame's transfer: Aravis' packet
    // resends (after packets it missed) are one way a transfer takes that long.
    auto stream = db.prepare("SELECT sum(resent_packets), sum(missing_packets) FROM stream_stats WHERE device_id = ?");
    stream.bind_all(id);
    const bool counted = stream.step() && !stream.column_null(0);
    out += fmt::format(
        "{}: {} frames of its connection {} arrived {:.1f} ms (median), {:.1f} ms (90 %) after their instant, "
        "their leader packets {:.1f} ms (median); {} came after it was decided; Aravis resent {} packets and "
        "missed {}\n",
        cameras.column_text(1), late_ms.size(), connection, late_p50, late_p90, median(leader_ms), too_late,
        counted ? std::to_string(stream.column_int(0)) : "?", counted ? std::to_string(stream.column_int(1)) : "?");
  }
  return out;
}
}  // namespace

// The board to print: a one-page PDF or a PNG; any other name is refused with what to use.
TEST(Calibration, TheBoardIsWrittenAsPdfOrPng) {
  const fs::path work = work_dir("calibrate-board");
  auto r = run_pvcap(fmt::format("calibrate board --out {}", (work / "board.pdf").string()));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("Print at 100 %"), std::string::npos) << r.output;
  EXPECT_EQ(read_all(work / "board.pdf").rfind("%PDF-1.4", 0), 0u);
  r = run_pvcap(fmt::format("calibrate board --out {}", (work / "board.png").string()));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  const cv::Mat png = pvcap::testing::read_picture(work / "board.png", /*grey=*/true);
  // 10 x 7 squares of 25 mm and a 12 mm margin at 12 px/mm.
  EXPECT_EQ(png.size(), cv::Size(int(274 * 12), int(199 * 12)));
  r = run_pvcap(fmt::format("calibrate board --out {}", (work / "board.txt").string()));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("the board is written as .pdf or .png"), std::string::npos) << r.output;
}

// A board session, then intrinsics from it: focal length within 0.5 % and principal point within
// 2 px of the simulator's lens for every camera (the command checks and exits 1 otherwise).
TEST(Calibration, BoardSessionGivesEveryCamerasIntrinsicsWithinTargets) {
  const fs::path work = work_dir("calibrate-intrinsics");
  const fs::path rig = write_full_size_board_rig(work);
  const auto board = run_pvcap(fmt::format("session --rig {} --board --duration 25 --root {} --no-web", rig.string(),
                                           (work / "board").string()));
  ASSERT_EQ(board.exit_code, 0) << board.output;
  const fs::path session = only_session(work / "board");
  // The live coverage told the operator, camera by camera, what the views still lacked (or that
  // they were covered), by the rule the intrinsics tell their result by.
  for (int c = 0; c < 4; ++c)
    EXPECT_NE(board.output.find(fmt::format("board coverage: cam{}: ", c)), std::string::npos) << board.output;
  {
    // Every camera's images are in the samples the intrinsics read: CI once found cam2's board in 1 of
    // its 150 (the cause not in the log). Under a busy machine a camera misses some groups (76 % of
    // samples at the least beside a second simulated rig); half is far from both.
    pvcap::sqlite::Database db(session / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
    auto samples = db.prepare("SELECT count(*) FROM samples");
    ASSERT_TRUE(samples.step());
    const std::int64_t total = samples.column_int(0);
    auto done = db.prepare("SELECT message FROM events WHERE kind = 'realign_done'");
    const std::string realigned = done.step() ? done.column_text(0) : "(no realign_done event)";
    auto per_camera = db.prepare(
        "SELECT d.name, (SELECT count(*) FROM sample_frames sf WHERE sf.device_id = d.id) FROM devices d WHERE "
        "d.kind = 'camera' ORDER BY d.name");
    const std::string lateness = lateness_by_camera(db);
    std::printf("%s", lateness.c_str());  // in the test log whatever the outcome
    int cameras = 0;
    for (; per_camera.step(); ++cameras)
      EXPECT_GE(2 * per_camera.column_int(1), total)
          << per_camera.column_text(0) << " is in " << per_camera.column_int(1) << " of " << total
          << " samples; the re-mapping said: " << realigned << "\n"
          << lateness << "the board session said:\n"
          << board.output;
    EXPECT_EQ(cameras, 4);
  }
  const auto intrinsics =
      run_pvcap(fmt::format("calibrate intrinsics {} --rig {} --ground-truth {} --save-views {}", session.string(),
                            rig.string(), (session / "sim-truth").string(), (work / "views").string()));
  // The margins, in the test log whatever the outcome (the principal point's is the thin one).
  for (std::size_t p = intrinsics.output.find("against the truth"); p != std::string::npos;
       p = intrinsics.output.find("against the truth", p + 1))
    std::printf("%s\n", intrinsics.output.substr(p, intrinsics.output.find('\n', p) - p).c_str());
  // A camera that saw too little is explained by what the board session said about it.
  EXPECT_EQ(intrinsics.exit_code, 0) << intrinsics.output << "\nthe board session said:\n" << board.output;
  EXPECT_EQ(count(intrinsics.output, "(within targets)"), 4) << intrinsics.output;
  const fs::path file = work / "rig.calibration.yaml";
  ASSERT_TRUE(fs::exists(file)) << "the calibration file goes beside the rig file";
  auto cal = pvcap::calib::load_rig_calibration(file);
  ASSERT_TRUE(cal) << cal.error().message;
  ASSERT_EQ(cal.value().cameras.size(), 4u);
  for (const auto& c : cal.value().cameras) {
    ASSERT_TRUE(c.intrinsics);
    EXPECT_EQ(c.intrinsics->method, "charuco_intrinsics");
    EXPECT_GE(c.intrinsics->details.at("views").get<int>(), 8);
    EXPECT_FALSE(c.pad) << "no pose before the pad is calibrated";
  }
  // The views each fit worked from, kept to fit again elsewhere (the fit from a file: LensFit.*):
  // at least one per view the fit used, at the session's image size.
  for (const auto& c : cal.value().cameras) {
    auto views = pvcap::calib::load_board_views(work / "views" / (c.name + ".board-views.yaml"));
    ASSERT_TRUE(views) << views.error().message;
    EXPECT_EQ(views.value().image_size, cv::Size(1920, 1080)) << c.name;
    EXPECT_GE(views.value().views.size(), std::size_t(c.intrinsics->details.at("views").get<int>())) << c.name;
  }
  // The session keeps what was measured from it.
  auto reader = pvcap::SessionReader::open(session);
  ASSERT_TRUE(reader);
  auto rows = reader.value()->calibrations();
  ASSERT_TRUE(rows);
  EXPECT_EQ(rows.value().size(), 4u);
}

// The pad's pose and homography from a recorded session with intrinsics given (the truth's, written
// as a calibration file, so this test does not need a board session): pad corners within 0.3 px
// median and 1 px max of the truth in every camera; the session and the next session record it.
TEST(Calibration, PadCornersFromASessionMatchTheTruthAndLaterSessionsRecordTheCalibration) {
  const fs::path work = work_dir("calibrate-pad");
  const fs::path rig = write_full_size_rig(work);
  // 8 s: four presses of the simulated Sensel (one every 2 s) for the press check. (4 s and two
  // presses were too few: on a loaded PC the full-size rig's start drops frames for its first
  // seconds, and CI once had no frame of cam1 during either press.)
  const auto first =
      run_pvcap(fmt::format("session --rig {} --duration 8 --root {} --no-web", rig.string(), (work / "s1").string()));
  ASSERT_EQ(first.exit_code, 0) << first.output;
  const fs::path session = only_session(work / "s1");

  // Without intrinsics: one clear message, exit 2.
  const auto missing = run_pvcap(fmt::format("calibrate pad {} --rig {}", session.string(), rig.string()));
  EXPECT_EQ(missing.exit_code, 2) << missing.output;
  EXPECT_NE(missing.output.find("no calibration file with the cameras' intrinsics"), std::string::npos)
      << missing.output;

  auto truth = pvcap::sim::read_rig_truth(session / "sim-truth");
  ASSERT_TRUE(truth) << truth.error().message;
  const fs::path file = work / "rig.calibration.yaml";
  ASSERT_EQ(write_truth_lenses(session, file), "");

  const auto pad = run_pvcap(fmt::format("calibrate pad {} --rig {} --ground-truth {}", session.string(), rig.string(),
                                         (session / "sim-truth").string()));
  EXPECT_EQ(pad.exit_code, 0) << pad.output;
  EXPECT_EQ(count(pad.output, "(within targets)"), 4) << pad.output;
  EXPECT_EQ(count(pad.output, "10 markers"), 4) << pad.output;
  auto cal = pvcap::calib::load_rig_calibration(file);
  ASSERT_TRUE(cal) << cal.error().message;
  for (std::size_t i = 0; i < 4; ++i) {
    const auto& c = cal.value().cameras[i];
    ASSERT_TRUE(c.pad && c.pad_corners_px);
    for (std::size_t k = 0; k < 4; ++k)
      EXPECT_LT(cv::norm((*c.pad_corners_px)[k] - truth.value().cameras[i].pad_corners_px[k]), 1.0)
          << c.name << " corner " << k;
  }
  {
    auto reader = pvcap::SessionReader::open(session);
    ASSERT_TRUE(reader);
    auto rows = reader.value()->calibrations();
    ASSERT_TRUE(rows);
    ASSERT_EQ(rows.value().size(), 4u);
    EXPECT_EQ(rows.value()[0].method, "pad_markers");
    EXPECT_LT(*rows.value()[0].rms_mm, 0.5);
  }

  // The press check: each press's pressure centroid against the fingertip each camera sees, within
  // 1 mm on the pad (the simulator's truth puts both at the same point).
  const auto check = run_pvcap(fmt::format("calibrate check {} --rig {}", session.string(), rig.string()));
  EXPECT_EQ(check.exit_code, 0) << check.output;
  const std::regex line(
      R"((cam\d): (\d+) presses; pressure vs fingertip: median ([\d.]+) px / ([\d.]+) mm, max ([\d.]+) px / ([\d.]+) mm)");
  int cameras_checked = 0;
  for (std::sregex_iterator it(check.output.begin(), check.output.end(), line), end; it != end; ++it) {
    ++cameras_checked;
    EXPECT_GE(std::stoi((*it)[2]), 1) << (*it)[0];
    EXPECT_LE(std::stod((*it)[6]), 1.0) << (*it)[0];
  }
  EXPECT_EQ(cameras_checked, 4) << check.output;

  // The next session on this rig records the calibration it was made with.
  const auto second =
      run_pvcap(fmt::format("session --rig {} --duration 2 --root {} --no-web", rig.string(), (work / "s2").string()));
  ASSERT_EQ(second.exit_code, 0) << second.output;
  auto reader = pvcap::SessionReader::open(only_session(work / "s2"));
  ASSERT_TRUE(reader);
  auto rows = reader.value()->calibrations();
  ASSERT_TRUE(rows);
  ASSERT_EQ(rows.value().size(), 4u);
  EXPECT_EQ(rows.value()[0].method, "pad_markers");
  EXPECT_NE(rows.value()[0].details_json.find("rig.calibration.yaml"), std::string::npos);

  // A damaged calibration file is said, and the session is recorded anyway.
  std::ofstream(file) << "pvcap_calibration: [unclosed\n";
  const auto third =
      run_pvcap(fmt::format("session --rig {} --duration 2 --root {} --no-web", rig.string(), (work / "s3").string()));
  EXPECT_EQ(third.exit_code, 0) << third.output;
  EXPECT_TRUE(
      std::regex_search(third.output, std::regex(R"(rig\.calibration\.yaml:\d+: YAML syntax error.*the session is )"
                                                 R"(recorded without it)")))
      << third.output;
}
