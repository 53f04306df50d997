// The session report end to end: a protocol session's report.html opens in a real browser without
// errors and its counts are the store's own (counted here with SQL); the sync self-check finds
// latencies the rig file does not declare, injected into the simulated cameras.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "calib/rig_calibration.h"
#include "headless_browser.h"
#include "session_under_test.h"
#include "sim/truth.h"
#include "storage/index/database.h"

namespace fs = std::filesystem;
using pvcap::testing::only_session;
using namespace pvcap::testing;
using nlohmann::json;

namespace {

const fs::path kScreenshots = fs::path(PVCAP_BINARY_DIR) / "tests" / "screenshots";

json report_json(const fs::path& session) {
  const auto r = run_pvcap(fmt::format("--log-level warn report {} --json", session.string()));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  // stdout is the JSON (progress goes to a terminal only).
  return json::parse(r.output.substr(r.output.find('{')), nullptr, false);
}

std::int64_t scalar(pvcap::sqlite::Database& db, const std::string& sql, std::int64_t id = -1) {
  auto q = db.prepare(sql);
  if (id >= 0) q.bind_all(id);
  return q.step() ? q.column_int(0) : -1;
}

}  // namespace

TEST(Report, AProtocolSessionsReportOpensInABrowserAndItsCountsAreTheStores) {
  const fs::path work = work_dir("report");
  // cam2 names its features in SFNC 2's way and was left on automatic white balance (by another
  // program, say): pvcap records with it, and the report warns.
  std::ofstream(work / "rig.yaml") << sim_rig_yaml({{}, {}, {.node_map = "sfnc2", .white_balance_auto = true}, {}}, 320,
                                                   240, 30, 15, "free-run", /*sensel=*/true);
  const auto session_run = run_pvcap(fmt::format(
      "session --rig {} --root {} --protocol {} --auto --fast --participant R01 --skin-tone medium --no-web",
      (work / "rig.yaml").string(), (work / "sessions").string(),
      write_press_protocol(work, "[low, high]", 0.5, 0.4, 1.5, 0.3).string()));
  ASSERT_EQ(session_run.exit_code, 0) << session_run.output;
  const fs::path session = only_session(work / "sessions");
  // The console's report is short and points to the page, written when the session ended.
  EXPECT_NE(session_run.output.find("full report (plots, sync self-check, calibration): " +
                                    (session / "report.html").string()),
            std::string::npos)
      << session_run.output;
  EXPECT_EQ(session_run.output.find("peak mm2"), std::string::npos)
      << "the take table belongs in report.txt and report.html, not on the console";
  EXPECT_NE(session_run.output.find("4 takes done of 4 in the plan"), std::string::npos) << session_run.output;
  EXPECT_NE(read_all(session / "report.txt").find("peak mm2"), std::string::npos);
  ASSERT_TRUE(fs::exists(session / "report.html"));
  EXPECT_LT(fs::file_size(session / "report.html"), 5'000'000u);

  const json r = report_json(session);
  ASSERT_TRUE(r.is_object());
  pvcap::sqlite::Database db(session / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
  for (const auto& s : r["streams"]) {
    SCOPED_TRACE(s["name"].get<std::string>());
    EXPECT_TRUE(s["reconciles"].get<bool>());
    const std::int64_t id =
        scalar(db, fmt::format("SELECT id FROM devices WHERE name = '{}'", s["name"].get<std::string>()));
    EXPECT_EQ(s["not_received"].get<std::int64_t>(),
              scalar(db, "SELECT coalesce(sum(count), 0) FROM drops WHERE device_id = ?", id));
    if (s["kind"] == "camera") {
      EXPECT_EQ(s["frames"].get<std::int64_t>(), scalar(db, "SELECT count(*) FROM frames WHERE device_id = ?", id));
      EXPECT_EQ(s["in_video"].get<std::int64_t>(),
                scalar(db, "SELECT count(*) FROM frames WHERE device_id = ? AND kept = 1", id));
      auto q = db.prepare("SELECT reason, count(*) FROM frames WHERE device_id = ? AND kept = 0 GROUP BY reason");
      q.bind_all(id);
      std::size_t reasons = 0;
      while (q.step()) {
        ++reasons;
        EXPECT_EQ(s["not_kept"].value(q.column_text(0), std::int64_t(-1)), q.column_int(1)) << q.column_text(0);
      }
      EXPECT_EQ(s["not_kept"].size(), reasons);
      EXPECT_GT(s["not_kept"].value("subsampled", 0), 0) << "30 Hz cameras kept at 15 Hz";
    } else {
      EXPECT_EQ(s["frames"].get<std::int64_t>(),
                scalar(db, "SELECT count(*) FROM pressure_frames WHERE device_id = ?", id));
    }
  }
  EXPECT_EQ(r["streams"].size(), std::size_t(scalar(db, "SELECT count(*) FROM devices")));
  EXPECT_EQ(r["pairing"]["samples"].get<std::int64_t>(), scalar(db, "SELECT count(*) FROM samples"));
  EXPECT_EQ(r["pairing"]["unpaired"].get<std::int64_t>(),
            scalar(db, "SELECT count(*) FROM samples WHERE pressure_sequence IS NULL"));
  EXPECT_EQ(r["pairing"]["timeline_counts"]["samples"].get<std::int64_t>(),
            scalar(db, "SELECT count FROM timeline_counts WHERE what = 'samples'"));
  // Every stream's intervals and clock model are there; the takes are the protocol's.
  EXPECT_EQ(r["intervals"].size(), 5u);
  for (const auto& s : r["intervals"]) EXPECT_GT(s["series"].size(), 10u) << s["name"];
  EXPECT_EQ(r["clocks"].size(), 5u);
  ASSERT_EQ(r["protocol"]["takes"].size(), 4u) << r["protocol"].dump();
  for (const auto& t : r["protocol"]["takes"]) {
    EXPECT_EQ(t["status"], "done");
    EXPECT_TRUE(t.contains("start_s") && t.contains("end_s"));
  }
  EXPECT_GT(r["protocol"]["by_force"]["high"]["mean_newtons"].get<double>(),
            r["protocol"]["by_force"]["low"]["mean_newtons"].get<double>());
  EXPECT_EQ(r["session"]["participant"]["pseudonym"], "R01");
  // Every camera's whole state is there; cam2's automatic white balance is the one warning, and a
  // feature the cameras do not agree on.
  const json& state = r["camera_state"];
  EXPECT_EQ(state["cameras_with_state"], 4) << state.dump(1);
  ASSERT_EQ(state["warnings"].size(), 1u) << state.dump(1);
  EXPECT_NE(state["warnings"][0].get<std::string>().find("cam2: BalanceWhiteAuto is Continuous"), std::string::npos);
  bool white_balance_differs = false;
  for (const auto& d : state["differ_between_cameras"])
    white_balance_differs |=
        d["feature"] == "BalanceWhiteAuto" && d["values"]["cam2"] == "Continuous" && d["values"]["cam0"] == "(none)";
  EXPECT_TRUE(white_balance_differs) << state.dump(1);
  EXPECT_TRUE(state["previous_session"].is_null()) << "the first session of the rig in its folder";
  EXPECT_EQ(scalar(db,
                   "SELECT json_extract(settings_json, '$.feature_bag.ExposureTime') FROM devices WHERE name = "
                   "'cam2'"),
            scalar(db, "SELECT json_extract(settings_json, '$.exposure_us') FROM devices WHERE name = 'cam2'"));
  // No calibration was recorded: the self-check says so for every camera instead of guessing.
  for (const auto& c : r["self_check"]["cameras"]) {
    EXPECT_TRUE(c["offset_ms"].is_null());
    EXPECT_NE(c["verdict"].get<std::string>().find("no pad calibration"), std::string::npos);
  }

  // The page in a real browser: no errors, every section there, a screenshot kept for people.
  HeadlessBrowser browser(1200, 900);
  if (!browser.ok()) GTEST_SKIP() << "chromium is not installed";
  const std::string tab = browser.open("file://" + (session / "report.html").string());
  ASSERT_FALSE(tab.empty());
  bool loaded = false;  // navigation returns before the page has loaded
  for (int i = 0; i < 200 && !loaded; ++i) {
    loaded =
        browser.eval(tab, "document.readyState === 'complete' && document.title.startsWith('pvcap report')") == true;
    if (!loaded) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_TRUE(loaded);
  const std::string dom = browser.dom(tab);
  for (const char* section :
       {"Captured and lost", "Sync self-check", "Frame intervals", "Clock models", "Pairing", "Protocol", "Calibration",
        "Counts reconcile with the store", "Camera state", "warning: cam2: BalanceWhiteAuto is Continuous"})
    EXPECT_NE(dom.find(section), std::string::npos) << section;
  EXPECT_GE(browser.eval(tab, "document.querySelectorAll('svg').length").get<int>(), 12);
  EXPECT_EQ(browser.eval(tab, "document.querySelectorAll('script, link[rel=stylesheet]').length").get<int>(), 0)
      << "self-contained: nothing to fetch";
  EXPECT_GE(browser.eval(tab, "document.querySelectorAll('img').length").get<int>(), 4) << "a thumbnail per camera";
  fs::create_directories(kScreenshots);
  EXPECT_TRUE(browser.screenshot(tab, kScreenshots / "report.png"));
  EXPECT_TRUE(browser.errors().empty()) << browser.errors().front();
  std::printf("report screenshot: %s\n", (kScreenshots / "report.png").c_str());
}

// Latencies the rig file does not declare (cam1 +7 ms, cam2 -5 ms; cam0 and cam3 none), injected
// into the simulated cameras' pixels: the self-check recovers each within 2 ms from 12 of the ~18
// isolated presses of a 20 s session (a press every 1.035 s: the self-check uses at most 12, so the
// 40 s session it had, a press every 2.07 s, spent 20 s of the suite on presses it did not use).
TEST(Report, TheSyncSelfCheckFindsLatenciesTheRigFileDoesNotDeclare) {
  const fs::path work = work_dir("report-self-check");
  std::string rig = read_all(fs::path(PVCAP_SOURCE_DIR) / "rig-configs" / "sim.yaml");
  auto replace = [&](const std::string& from, const std::string& to) {
    const auto at = rig.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    rig.replace(at, from.size(), to);
  };
  for (int i = 0; i < 4; ++i) {
    ASSERT_NO_FATAL_FAILURE(replace("width: 1920", "width: 960"));
    ASSERT_NO_FATAL_FAILURE(replace("height: 1080", "height: 540"));
  }
  // A press period off the 15 Hz grid (15.5 samples): successive presses are sampled at different
  // phases, as a person's are.
  ASSERT_NO_FATAL_FAILURE(replace("period_s: 2.0", "period_s: 1.035"));
  ASSERT_NO_FATAL_FAILURE(
      replace("drift_ppm: -65, jitter_us: 20", "drift_ppm: -65, jitter_us: 20, undeclared_latency_ms: 7"));
  ASSERT_NO_FATAL_FAILURE(
      replace("drift_ppm: 90, jitter_us: 20", "drift_ppm: 90, jitter_us: 20, undeclared_latency_ms: -5"));
  { std::ofstream(work / "rig.yaml") << rig; }
  const auto run = run_pvcap(fmt::format("session --rig {} --duration 20 --root {} --no-web",
                                         (work / "rig.yaml").string(), (work / "s").string()));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const fs::path session = only_session(work / "s");

  // The cameras' lenses as the simulator made them (so this test needs no board session), then the
  // pad calibrated from the session itself: the self-check finds the contact through it.
  ASSERT_EQ(write_truth_lenses(session, work / "lenses.yaml"), "");
  const auto pad =
      run_pvcap(fmt::format("calibrate pad {} --calibration {}", session.string(), (work / "lenses.yaml").string()));
  ASSERT_EQ(pad.exit_code, 0) << pad.output;

  const json r = report_json(session);
  ASSERT_TRUE(r.is_object());
  const json& sc = r["self_check"];
  EXPECT_GE(sc["presses_used"].get<int>(), 12) << sc.dump(1);
  std::printf("self-check: %d presses found, %d isolated, %d used\n", sc["presses_found"].get<int>(),
              sc["presses_isolated"].get<int>(), sc["presses_used"].get<int>());
  const double injected[] = {0, 7, -5, 0};
  for (std::size_t c = 0; c < 4; ++c) {
    const json& cam = sc["cameras"][c];
    std::printf("self-check %s: %s ms +- %s ms (injected %+.0f ms), %d presses\n",
                cam["name"].get<std::string>().c_str(), cam["offset_ms"].dump().c_str(),
                cam["uncertainty_ms"].dump().c_str(), injected[c], cam["presses"].get<int>());
    ASSERT_EQ(cam["verdict"], "ok") << cam.dump();
    EXPECT_NEAR(cam["offset_ms"].get<double>(), injected[c], 2.0) << cam.dump();
    EXPECT_LT(cam["uncertainty_ms"].get<double>(), 1.0) << cam.dump();
  }
}
