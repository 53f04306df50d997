// PTP time (rig file `ptp:`; docs/multihost.md). The host's, read from real linuxptp: two ptp4l in
// network namespaces of the test's own joined by a veth pair (tests/integration/ptp_pair.h; software
// timestamping, free_running 1: they measure, never adjust this machine's clock). The cameras', from
// the simulated SFNC 2 cameras' PTP features over GVCP (they lock after a delay, with a servo error).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <map>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "storage/index/database.h"
#include "sync/ptp_host.h"
#include "tests/integration/ptp_pair.h"
#include "tests/integration/session_under_test.h"

namespace fs = std::filesystem;
using namespace pvcap::testing;

namespace {

// The follower's state once it follows the grandmaster and has measured its offset (ptp4l picks its
// master within seconds).
pvcap::Result<pvcap::sync::PtpHostState> wait_until_following(const fs::path& socket, std::chrono::seconds limit) {
  const auto end = std::chrono::steady_clock::now() + limit;
  pvcap::Result<pvcap::sync::PtpHostState> last = pvcap::Error{"not read yet"};
  while (std::chrono::steady_clock::now() < end) {
    last = pvcap::sync::PmcClient(socket).query();
    // Following another clock, its offset measured (within any limit).
    if (last && !last.value().is_grandmaster() && !pvcap::sync::ptp_host_out_of_time(last.value(), 1e12)) return last;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  return last;
}

// A rig of two simulated 320x240 cameras with the host's PTP time read from `socket`.
fs::path write_ptp_rig(const fs::path& dir, const fs::path& socket, double max_offset_us) {
  std::string yaml = sim_rig_yaml({{}, {}}, 320, 240, 30, 15);
  yaml += fmt::format("ptp:\n  cameras: false\n  ptp4l_socket: {}\n  max_offset_us: {}\n", socket.string(),
                      max_offset_us);
  const fs::path rig = dir / "rig.yaml";
  std::ofstream(rig) << yaml;
  return rig;
}

int count_events(const fs::path& session, const std::string& kind) {
  pvcap::sqlite::Database db(session / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
  auto q = db.prepare("SELECT count(*) FROM events WHERE kind = ?");
  q.bind(1, kind);
  return q.step() ? int(q.column_int(0)) : -1;
}

}  // namespace

TEST(PtpHost, PmcReadsTheGrandmasterAndAFollowerFromRealPtp4l) {
  const fs::path work = work_dir("ptp-pmc");
  PtpPair pair(work / "ptp");
  ASSERT_EQ(pair.start(), "");
  const auto follower = wait_until_following(pair.follower_socket(), std::chrono::seconds(20));
  ASSERT_TRUE(follower) << follower.error().message << "\n" << read_all(pair.follower_log());
  const auto gm = pvcap::sync::PmcClient(pair.grandmaster_socket()).query();
  ASSERT_TRUE(gm) << gm.error().message;
  std::printf("grandmaster: %s\nfollower: %s\n", pvcap::sync::describe(gm.value()).c_str(),
              pvcap::sync::describe(follower.value()).c_str());
  EXPECT_TRUE(gm.value().is_grandmaster());
  EXPECT_EQ(follower.value().grandmaster, gm.value().clock_identity) << "the follower follows the other namespace";
  EXPECT_EQ(follower.value().steps_removed, 1);
  // One clock on both ends (the namespaces share this machine's): what ptp4l measures is its
  // software timestamps' noise, tens of microseconds at most on a loaded 2-core machine.
  EXPECT_LT(std::abs(follower.value().offset_ns), 200'000.0);
  EXPECT_GT(follower.value().path_delay_ns, 0.0);
  // A socket no ptp4l serves: an Error that names it, within the time limit.
  const auto t = std::chrono::steady_clock::now();
  const auto none = pvcap::sync::PmcClient(work / "no-ptp4l.sock").query();
  ASSERT_FALSE(none);
  EXPECT_NE(none.error().message.find("no answer from ptp4l at " + (work / "no-ptp4l.sock").string()), std::string::npos)
      << none.error().message;
  EXPECT_LT(std::chrono::steady_clock::now() - t, std::chrono::seconds(2));
}

TEST(PtpHost, AHostOutOfTimeIsRefusedBeforeAnyRecordingAndWhatToDoIsSaid) {
  const fs::path work = work_dir("ptp-refused");
  // No ptp4l at all.
  const fs::path rig = write_ptp_rig(work, work / "no-ptp4l.sock", 100);
  const auto r = run_pvcap(fmt::format("session --rig {} --duration 2 --root {} --no-web", rig.string(),
                                       (work / "sessions").string()));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("the host's PTP time (ptp: (line"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("start ptp4l with that uds_address (docs/multihost.md)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("no session was recorded"), std::string::npos) << r.output;
  EXPECT_TRUE(!fs::exists(work / "sessions") || fs::is_empty(work / "sessions")) << "a refused start leaves nothing";
  // A ptp4l that follows, but beyond the limit the rig file sets (a nanosecond: software timestamps
  // never come that close).
  PtpPair pair(work / "ptp");
  ASSERT_EQ(pair.start(), "");
  ASSERT_TRUE(wait_until_following(pair.follower_socket(), std::chrono::seconds(20)));
  const fs::path tight = write_ptp_rig(work, pair.follower_socket(), 0.001);
  const auto t = run_pvcap(fmt::format("session --rig {} --duration 2 --root {} --no-web", tight.string(),
                                       (work / "sessions").string()));
  EXPECT_EQ(t.exit_code, 1) << t.output;
  EXPECT_NE(t.output.find("the host is not in PTP time"), std::string::npos) << t.output;
  EXPECT_NE(t.output.find("over the limit of 1 ns (ptp.max_offset_us)"), std::string::npos) << t.output;
  EXPECT_TRUE(!fs::exists(work / "sessions") || fs::is_empty(work / "sessions"));
}

TEST(PtpHost, ASessionStoresTheHostsTimeEverySecondAndNamesEachSecondPtp4lIsGone) {
  const fs::path work = work_dir("ptp-session");
  PtpPair pair(work / "ptp");
  ASSERT_EQ(pair.start(), "");
  ASSERT_TRUE(wait_until_following(pair.follower_socket(), std::chrono::seconds(20)));
  const fs::path rig = write_ptp_rig(work, pair.follower_socket(), 500);
  const fs::path log = work / "pvcap.log";
  const pid_t pid = spawn_pvcap(
      fmt::format("session --rig {} --duration 8 --root {} --no-web", rig.string(), (work / "sessions").string()), log);
  ASSERT_GT(pid, 0);
  // The follower's ptp4l dies 3 s into the recording (a host's ptp4l stopped), and is not back.
  ASSERT_TRUE(wait_for_recorded_seconds(log, 3, std::chrono::seconds(30))) << read_all(log);
  pair.stop_follower();
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  const std::string out = read_all(log);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << out;
  EXPECT_NE(out.find("the host's PTP time: UNCALIBRATED of"), std::string::npos) << out;
  EXPECT_NE(out.find("no answer from ptp4l at " + pair.follower_socket().string()), std::string::npos) << out;
  EXPECT_NE(out.find("WARNING: host PTP time:"), std::string::npos) << out;
  const fs::path session = only_session(work / "sessions");
  const int states = count_events(session, "ptp_host_state");
  const int out_of_time = count_events(session, "ptp_host_out_of_time");
  std::printf("%d readings stored, %d seconds out of time\n", states, out_of_time);
  EXPECT_GE(states, 2) << "read each second while ptp4l ran";
  EXPECT_GE(out_of_time, 3) << "each second without ptp4l named";
  EXPECT_LE(states + out_of_time, 12) << "once a second, not more";
  pvcap::sqlite::Database db(session / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
  auto q = db.prepare("SELECT message FROM events WHERE kind = 'ptp_host_state' ORDER BY host_ns LIMIT 1");
  ASSERT_TRUE(q.step());
  const auto j = nlohmann::json::parse(q.column_text(0));
  EXPECT_EQ(j.at("port_state"), "UNCALIBRATED");
  EXPECT_TRUE(j.at("in_time").get<bool>());
  EXPECT_TRUE(j.at("gm_present").get<bool>());
  EXPECT_FALSE(j.at("grandmaster").get<std::string>().empty());
  // The report sums the readings up and lists the stretch out of time (docs/report.md, "PTP time").
  const auto report = run_pvcap(fmt::format("report {} --json", session.string()));
  ASSERT_EQ(report.exit_code, 0) << report.output;
  const auto r = nlohmann::json::parse(report.output.substr(report.output.find('{')));
  ASSERT_TRUE(r.contains("ptp_time")) << report.output;
  EXPECT_EQ(r["ptp_time"]["readings"], states);
  EXPECT_EQ(r["ptp_time"]["seconds_out_of_time"], out_of_time);
  ASSERT_EQ(r["ptp_time"]["out_of_time"].size(), 1u) << r["ptp_time"].dump();
  EXPECT_GE(r["ptp_time"]["out_of_time"][0]["from_s"].get<double>(), 2.5);
  for (const auto& e : r["events"]) EXPECT_NE(e["kind"], "ptp_host_state") << "readings are summed up, not listed";
}

namespace {
// Two SFNC 2 cameras with PTP; `keys` are each camera's sim keys.
fs::path write_ptp_camera_rig(const fs::path& dir, const std::string& keys0, const std::string& keys1,
                              double lock_wait_s) {
  std::vector<SimCameraSpec> cams(2);
  cams[0].node_map = cams[1].node_map = "sfnc2";
  cams[0].sim_keys = keys0;
  cams[1].sim_keys = keys1;
  std::string yaml = sim_rig_yaml(cams, 320, 240, 30, 15);
  yaml += fmt::format("ptp:\n  host: false\n  lock_wait_s: {}\n", lock_wait_s);
  const fs::path rig = dir / "rig.yaml";
  std::ofstream(rig) << yaml;
  return rig;
}
}  // namespace

TEST(PtpTime, CamerasAreLockedBeforeTheStartThenReadEachSecondAndALostLockIsNamedEachSecond) {
  const fs::path work = work_dir("ptp-cameras");
  // Both lock 1.5 s after PTP is enabled (at their configuration); cam1 loses lock 4 s after that, for 2 s.
  const fs::path rig = write_ptp_camera_rig(work, "ptp_lock_after_s: 1.5, ptp_servo_error_ns: 40",
                                            "ptp_lock_after_s: 1.5, ptp_servo_error_ns: 40, ptp_unlock_at_s: 4, "
                                            "ptp_unlock_for_s: 2",
                                            10);
  const auto r = run_pvcap(
      fmt::format("session --rig {} --duration 8 --root {} --no-web", rig.string(), (work / "sessions").string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("waiting up to 10 s for the cameras to lock to PTP time"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("every camera locked to PTP time after"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("cam1 (serial PVSIM1 at 127.0.0.3): PTP not locked: Uncalibrated, servo Unknown"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("cam1 (serial PVSIM1 at 127.0.0.3): PTP locked again: Slave, servo Locked"), std::string::npos)
      << r.output;
  const fs::path session = only_session(work / "sessions");
  pvcap::sqlite::Database db(session / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
  auto q = db.prepare(
      "SELECT d.name, e.kind, e.message FROM events e JOIN devices d ON d.id = e.device_id WHERE e.kind LIKE "
      "'ptp_camera_%' ORDER BY e.host_ns");
  std::map<std::string, int> readings, locked, out_of_lock;
  double worst_locked_offset = 0;
  while (q.step()) {
    const std::string camera = q.column_text(0), kind = q.column_text(1), message = q.column_text(2);
    if (kind == "ptp_camera_out_of_lock") {
      ++out_of_lock[camera];
      continue;
    }
    ++readings[camera];
    const auto j = nlohmann::json::parse(message);
    if (!j.at("locked").get<bool>()) continue;
    ++locked[camera];
    EXPECT_EQ(j.at("status"), "Slave");
    EXPECT_EQ(j.at("servo"), "Locked");
    worst_locked_offset = std::max(worst_locked_offset, std::abs(j.at("offset_ns").get<double>()));
  }
  std::printf("readings cam0 %d (locked %d), cam1 %d (locked %d, %d s out of lock); worst locked offset %.0f ns\n",
              readings["cam0"], locked["cam0"], readings["cam1"], locked["cam1"], out_of_lock["cam1"],
              worst_locked_offset);
  for (const char* cam : {"cam0", "cam1"}) EXPECT_GE(readings[cam], 5) << cam << ": read each second";
  EXPECT_EQ(locked["cam0"], readings["cam0"]) << "cam0 never lost lock";
  EXPECT_EQ(out_of_lock["cam0"], 0);
  EXPECT_GE(out_of_lock["cam1"], 1) << "cam1's 2 s out of lock named";
  EXPECT_LE(out_of_lock["cam1"], 3);
  EXPECT_EQ(locked["cam1"] + out_of_lock["cam1"], readings["cam1"]);
  EXPECT_LE(worst_locked_offset, 5 * 40.0) << "the servo's error, 40 ns";
  // The report: each camera's readings and its stretch out of lock.
  const auto report = run_pvcap(fmt::format("report {} --json", session.string()));
  ASSERT_EQ(report.exit_code, 0) << report.output;
  const auto j = nlohmann::json::parse(report.output.substr(report.output.find('{')));
  ASSERT_TRUE(j.contains("ptp_time")) << report.output;
  const auto& cams = j["ptp_time"]["cameras"];
  ASSERT_EQ(cams.size(), 2u);
  EXPECT_EQ(cams[1]["name"], "cam1");
  EXPECT_EQ(cams[1]["seconds_out_of_lock"], out_of_lock["cam1"]);
  ASSERT_EQ(cams[1]["out_of_lock"].size(), 1u) << cams.dump();
  EXPECT_TRUE(cams[0]["out_of_lock"].empty());
}

TEST(PtpTime, ACameraNotLockedInTimeOrWithoutPtpIsRefusedByName) {
  const fs::path work = work_dir("ptp-camera-refused");
  const fs::path rig = write_ptp_camera_rig(work, "ptp_lock_after_s: 0.5", "ptp_lock_after_s: 60", 1.5);
  const auto slow = run_pvcap(
      fmt::format("session --rig {} --duration 2 --root {} --no-web", rig.string(), (work / "sessions").string()));
  EXPECT_EQ(slow.exit_code, 1) << slow.output;
  EXPECT_NE(slow.output.find("not locked to PTP time after 1.5 s (ptp.lock_wait_s): cam1 (serial PVSIM1 at "
                             "127.0.0.3): Listening, servo Unknown"),
            std::string::npos)
      << slow.output;
  EXPECT_EQ(slow.output.find("cam0 (serial PVSIM0 at 127.0.0.2): Listening"), std::string::npos) << "cam0 locked";
  EXPECT_NE(slow.output.find("no session was recorded: every camera of"), std::string::npos) << slow.output;
  EXPECT_TRUE(!fs::exists(work / "sessions") || fs::is_empty(work / "sessions"));
  // Aravis' own fake camera's names: no PTP at all.
  std::string yaml = sim_rig_yaml({{}}, 320, 240, 30, 15) + "ptp:\n  host: false\n";
  std::ofstream(work / "plain.yaml") << yaml;
  const auto plain = run_pvcap(fmt::format("session --rig {} --duration 2 --root {} --no-web",
                                           (work / "plain.yaml").string(), (work / "sessions").string()));
  EXPECT_EQ(plain.exit_code, 1) << plain.output;
  EXPECT_NE(plain.output.find("cam0 (serial PVSIM0 at 127.0.0.2): has no PTP feature (PtpEnable, GevIEEE1588 or "
                              "PtpMode)"),
            std::string::npos)
      << plain.output;
}
