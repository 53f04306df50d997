// Faults of a running session met through the real `pvcap session` on the simulated rig: a second
// recorder on the same rig, and a --root that cannot take a session (read-only, missing parent).
#include <gtest/gtest.h>

#include <grp.h>
#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <sys/mount.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <set>
#include <thread>

#include <fmt/format.h>

#include "session_under_test.h"
#include "storage/index/database.h"
#include "storage/index/session_reader.h"

namespace fs = std::filesystem;
using namespace pvcap::testing;

namespace {

fs::path write_rig(const fs::path& dir) {
  std::ofstream(dir / "rig.yaml") << sim_rig_yaml({{}, {}}, 320, 240, 30, 15, "free-run", /*sensel=*/true);
  return dir / "rig.yaml";
}

std::vector<fs::path> sessions_in(const fs::path& root) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(root, ec))
    if (e.is_directory() && e.path().filename().string()[0] != '.') out.push_back(e.path());
  return out;
}

// For a failure's message: the reasons of the sample frames not in a video, with their times.
std::string why_sample_frames_are_not_in_a_video(const fs::path& session) {
  pvcap::sqlite::Database db(session / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
  auto q = db.prepare(
      "SELECT sf.sample_id, sf.device_id, sf.sequence, coalesce(f.reason, 'no row'), (s.t_ns - x.started_host_ns) / "
      "1000000 FROM sample_frames sf JOIN samples s ON s.id = sf.sample_id, session x LEFT JOIN frames f USING "
      "(device_id, connection, sequence) WHERE f.kept IS NOT 1");
  std::string out = "\nsample frames not in a video:";
  while (q.step())
    out += fmt::format("\n  sample {} device {} sequence {}: {} at {} ms", q.column_int(0), q.column_int(1),
                       q.column_int(2), q.column_text(3), q.column_int(4));
  return out;
}

}  // namespace

TEST(SessionFaults, ASecondRecorderOnTheSameRigIsRefusedWithTheRunningOnesPidAndFolder) {
  const fs::path work = work_dir("one-recorder");
  const fs::path rig = write_rig(work);
  // The first records until it is stopped (Ctrl-C) after the second has tried: with a fixed 12 s it
  // had ended once before a loaded CI machine's second recorder reached the lock (its simulated rig
  // took 20 s to start), and the second then rightly recorded.
  const pid_t first = spawn_pvcap(
      fmt::format("session --rig {} --root {} --duration 300 --no-web", rig.string(), (work / "first").string()),
      work / "first.log");
  ASSERT_TRUE(wait_for_text(work / "first.log", "recording session", std::chrono::seconds(60)))
      << read_all(work / "first.log");
  const auto second = run_pvcap(
      fmt::format("session --rig {} --root {} --duration 3 --no-web", rig.string(), (work / "second").string()));
  EXPECT_EQ(read_all(work / "first.log").find("ended:"), std::string::npos) << "the first still records";
  ASSERT_EQ(kill(first, SIGINT), 0);
  int status = 0;
  ASSERT_EQ(waitpid(first, &status, 0), first);
  const auto running = sessions_in(work / "first");
  ASSERT_EQ(running.size(), 1u);
  EXPECT_EQ(second.exit_code, 1) << second.output;
  EXPECT_NE(second.output.find("is already recording"), std::string::npos) << second.output;
  EXPECT_NE(second.output.find(fmt::format("pid {}", first)), std::string::npos) << second.output;
  EXPECT_NE(second.output.find(running[0].string()), std::string::npos)
      << "names the running session's folder: " << second.output;
  EXPECT_TRUE(sessions_in(work / "second").empty()) << "the refused recorder left no session behind";
  // The first session never noticed.
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << read_all(work / "first.log");
  const auto v = run_pvcap("verify " + running[0].string());
  EXPECT_TRUE(v.exit_code == 0 || v.exit_code == 3) << v.output;
  // Once it has ended, the rig is free again (also after a kill: the kernel drops the lock).
  const auto third = run_pvcap(
      fmt::format("session --rig {} --root {} --duration 2 --no-web", rig.string(), (work / "third").string()));
  EXPECT_EQ(third.exit_code, 0) << third.output;
}

TEST(SessionFaults, ARootThatCannotTakeASessionEndsWithExit1AndAMessage) {
  if (geteuid() != 0) GTEST_SKIP() << "mounting the read-only filesystem needs root";
  const fs::path work = work_dir("bad-root");
  const fs::path rig = write_rig(work);
  // Read-only (root may write anywhere else: only a read-only mount refuses it).
  const fs::path readonly = work / "readonly";
  fs::create_directories(readonly);
  ASSERT_EQ(mount("tmpfs", readonly.c_str(), "tmpfs", MS_RDONLY | MS_NOSUID | MS_NODEV, "size=1m"), 0)
      << std::strerror(errno);
  const auto ro =
      run_pvcap(fmt::format("session --rig {} --root {} --duration 2 --no-web", rig.string(), readonly.string()));
  umount2(readonly.c_str(), MNT_DETACH);
  EXPECT_EQ(ro.exit_code, 1) << ro.output;
  EXPECT_NE(ro.output.find(readonly.string()), std::string::npos) << "names where: " << ro.output;
  EXPECT_NE(ro.output.find("cannot be written: Read-only file system"), std::string::npos) << "and why: " << ro.output;
  // A root under a regular file (a typo in the path) cannot be made either.
  std::ofstream(work / "a-file") << "x";
  const auto under_file = run_pvcap(fmt::format("session --rig {} --root {} --duration 2 --no-web", rig.string(),
                                                (work / "a-file" / "sessions").string()));
  EXPECT_EQ(under_file.exit_code, 1) << under_file.output;
  EXPECT_NE(under_file.output.find((work / "a-file").string()), std::string::npos) << under_file.output;
}

namespace {
// The rig of write_rig with the simulated Morph unplugged 3 s in and back (power-cycled) at 4.5 s,
// as `replug` says (empty: the same Morph).
fs::path write_replug_rig(const fs::path& dir, const std::string& replug) {
  std::string yaml = sim_rig_yaml({{}, {}}, 320, 240, 30, 15, "free-run", /*sensel=*/true);
  const std::string end = "period_s: 1.0}";
  const auto at = yaml.find(end);
  if (at == std::string::npos) return {};
  yaml.replace(at, end.size(), "period_s: 1.0, unplug_at_s: 3, replug_after_s: 4.5" + replug + "}");
  std::ofstream(dir / "rig.yaml") << yaml;
  return dir / "rig.yaml";
}

std::int64_t scalar(pvcap::sqlite::Database& db, const std::string& sql) {
  auto q = db.prepare(sql);
  EXPECT_TRUE(q.step()) << sql;
  return q.column_null(0) ? -1 : q.column_int(0);
}

// Records `seconds` on the replug rig (`replug` as for write_replug_rig): what pvcap said and the
// session folder (empty, with the failure said, when it did not record).
struct ReplugRun {
  fs::path work, session;
  std::string output;
};
ReplugRun record_replug(const std::string& name, const std::string& replug, double seconds) {
  ReplugRun r;
  r.work = work_dir(name);
  const fs::path rig = write_replug_rig(r.work, replug);
  if (rig.empty()) {
    ADD_FAILURE() << "the replug rig could not be written";
    return r;
  }
  const auto run = run_pvcap(fmt::format("session --rig {} --root {} --duration {} --no-web", rig.string(),
                                         (r.work / "sessions").string(), seconds));
  r.output = run.output;
  if (run.exit_code == 0) r.session = only_session(r.work / "sessions");
  if (r.session.empty()) ADD_FAILURE() << "exit " << run.exit_code << "\n" << run.output;
  return r;
}

}  // namespace

// The Morph unplugged and plugged back during a session: the operator is told both, the frames
// after it are a new connection (their sequences restart, and never collide with the first
// connection's), the time away is recorded as lost frames with the reason, and every sample still
// reads its own pressure frame.
TEST(SessionFaults, ASenselPluggedBackIsANewConnectionAndItsAbsenceIsRecordedAsLost) {
  const auto run = record_replug("replug", "", 9);
  ASSERT_FALSE(run.session.empty());
  const fs::path& session = run.session;
  EXPECT_NE(run.output.find("Sensel reconnected (serial SM01164910368), streaming again as connection 1"),
            std::string::npos)
      << run.output;
  pvcap::sqlite::Database db(session / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
  EXPECT_EQ(scalar(db, "SELECT count(*) FROM events WHERE kind = 'sensel_unplugged'"), 1);
  EXPECT_EQ(scalar(db, "SELECT count(*) FROM events WHERE kind = 'sensel_reconnected'"), 1);
  EXPECT_GT(scalar(db, "SELECT count(*) FROM pressure_frames WHERE connection = 0"), 200);
  EXPECT_GT(scalar(db, "SELECT count(*) FROM pressure_frames WHERE connection = 1"), 200);
  EXPECT_EQ(scalar(db,
                   "SELECT count(*) FROM (SELECT connection, sequence FROM pressure_frames GROUP BY 1, 2 "
                   "HAVING count(*) > 1)"),
            0)
      << "a sequence repeated within a connection";
  // Away from the unplug (3 s) to the reconnect (4.5 s, then the driver's next try, once a second):
  // 1.5-2.5 s, and the frames lost are that time at the rate the Morph kept before it went. Polled
  // (sync mode), it scans when asked, so on a loaded machine that rate is below its ~125 Hz: a fresh
  // clone's run beside a busy rig counted 116 lost, which a bound at 125 Hz (> 150) failed.
  const auto lost = scalar(db, "SELECT sum(count) FROM drops WHERE reason = 'unplugged' AND connection = 1");
  const double away_s = double(scalar(db,
                                      "SELECT (SELECT host_ns FROM events WHERE kind = 'sensel_reconnected') - "
                                      "(SELECT host_ns FROM events WHERE kind = 'sensel_unplugged')")) /
                        1e9;
  const double period_s =
      double(scalar(db,
                    "SELECT (max(device_ns) - min(device_ns)) / (count(*) - 1) FROM pressure_frames WHERE "
                    "connection = 0")) /
      1e9;
  std::printf("away %.3f s, connection 0 scanned every %.2f ms: %lld frames lost\n", away_s, period_s * 1e3,
              static_cast<long long>(lost));
  EXPECT_GE(away_s, 1.45);
  EXPECT_LE(away_s, 3.2);
  EXPECT_GT(period_s, 0.007);  // the emulator's medium-detail rate at most, ~125 Hz
  // The driver's own estimate of the rate counts the frames it read, the store those it kept: 3 %.
  EXPECT_NEAR(double(lost), away_s / period_s, 1 + 0.03 * away_s / period_s);
  // Samples on both sides pair with their own connection's frames, and each reads back.
  EXPECT_GT(scalar(db, "SELECT count(*) FROM samples WHERE pressure_connection = 1"), 20);
  EXPECT_EQ(scalar(db,
                   "SELECT count(*) FROM samples s WHERE pressure_sequence IS NOT NULL AND NOT EXISTS (SELECT 1 "
                   "FROM pressure_frames p WHERE p.connection = s.pressure_connection AND p.sequence = "
                   "s.pressure_sequence AND abs(p.mapped_ns - s.t_ns) <= 20000000)"),
            0)
      << "a sample names a pressure frame that is not the one near it";
  auto reader = pvcap::SessionReader::open(session);
  ASSERT_TRUE(reader) << reader.error().message;
  for (std::size_t i = 0; i < reader.value()->sample_count(); ++i) {
    auto s = reader.value()->sample(i, pvcap::PressureMode::Interpolated);
    ASSERT_TRUE(s) << i << ": " << s.error().message;
  }
}

// The Morph comes back under another name (its first tty is gone, as /dev/ttyACM0 coming back as
// /dev/ttyACM1): the driver finds it by its serial among the ports a Morph may be behind, says
// where, and records it as the next connection.
TEST(SessionFaults, ASenselBackUnderAnotherNameIsFoundByItsSerial) {
  const auto run = record_replug("renamed-morph", ", replug_renamed: true", 8);
  ASSERT_FALSE(run.session.empty());
  const fs::path& session = run.session;
  EXPECT_NE(run.output.find("is gone; the session's Morph (serial SM01164910368) is back on "), std::string::npos)
      << run.output;
  EXPECT_NE(run.output.find("morph-replugged"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("Sensel reconnected (serial SM01164910368), streaming again as connection 1"),
            std::string::npos)
      << run.output;
  pvcap::sqlite::Database db(session / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
  EXPECT_EQ(scalar(db, "SELECT count(*) FROM events WHERE kind = 'sensel_reconnected'"), 1);
  EXPECT_GT(scalar(db, "SELECT count(*) FROM pressure_frames WHERE connection = 1"), 200);
}

// Another Morph plugged in where the session's was unplugged is refused, loudly, and not recorded.
TEST(SessionFaults, ADifferentSenselPluggedInIsRefusedAndNotRecorded) {
  const auto run = record_replug("other-morph", ", replug_serial: SM99999999999", 7);
  ASSERT_FALSE(run.session.empty());
  const fs::path& session = run.session;
  EXPECT_NE(run.output.find("a different Sensel Morph (serial SM99999999999) answered where the session's (serial "
                            "SM01164910368) was unplugged; it is NOT recorded"),
            std::string::npos)
      << run.output;
  pvcap::sqlite::Database db(session / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
  EXPECT_EQ(scalar(db, "SELECT count(*) FROM events WHERE kind = 'sensel_wrong_device'"), 1)
      << "said once, not at every retry";
  EXPECT_EQ(scalar(db, "SELECT count(*) FROM events WHERE kind = 'sensel_reconnected'"), 0);
  EXPECT_EQ(scalar(db, "SELECT count(*) FROM pressure_frames WHERE connection <> 0"), 0);
}

// pvcap's own side falling behind (core/fault_injection.h): the Sensel's worker stalls with a small
// queue, later the index thread stalls with a small queue and little memory beyond it. Every
// pressure frame the device sent is a row or in a drop row with its reason (the Sensel's queue);
// the index loses no row: they wait, in memory and on disk, and every camera frame received is a
// row. The operator is told of each once, while recording.
TEST(SessionFaults, PressureFramesLostToASlowPvcapAreCountedAndASlowIndexLosesNoRow) {
  const fs::path work = work_dir("pvcap-behind");
  const fs::path rig = write_rig(work);
  setenv("PVCAP_FAULTS",
         "sensel_pipeline.stall_s=2,sensel_pipeline.stall_after_s=1,sensel.queue_frames=16,"
         "index_writer.stall_s=1.5,index_writer.stall_after_s=3.5,index_writer.queue_records=100,"
         "index_writer.overflow_memory_records=50",
         1);
  const auto run = run_pvcap(
      fmt::format("session --rig {} --root {} --duration 6 --no-web", rig.string(), (work / "sessions").string()));
  unsetenv("PVCAP_FAULTS");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  for (const std::string warning :
       {"frames lost because pvcap did not take them from the device", "session index: behind"}) {
    const auto first = run.output.find(warning);
    EXPECT_NE(first, std::string::npos) << run.output;
    EXPECT_EQ(run.output.find(warning, first + 1), std::string::npos) << "said more than once: " << run.output;
  }
  const fs::path session = only_session(work / "sessions");
  ASSERT_FALSE(session.empty());
  pvcap::sqlite::Database db(session / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
  const std::int64_t sensel = scalar(db, "SELECT id FROM devices WHERE kind = 'sensel'");
  // Frames the Sensel's queue had no room for: drop rows of their own, never also stored.
  std::set<std::int64_t> stored;
  auto p = db.prepare("SELECT sequence FROM pressure_frames WHERE device_id = ? AND connection = 0");
  p.bind(1, sensel);
  while (p.step()) stored.insert(p.column_int(0));
  ASSERT_GT(stored.size(), 300u);
  std::uint64_t overflowed = 0, dropped = 0;
  auto d = db.prepare("SELECT first_sequence, count, reason FROM drops WHERE device_id = ? AND connection = 0");
  d.bind(1, sensel);
  while (d.step()) {
    for (std::int64_t q = d.column_int(0); q < d.column_int(0) + d.column_int(1); ++q)
      EXPECT_EQ(stored.count(q), 0u) << "sequence " << q << " is both stored and dropped";
    dropped += std::uint64_t(d.column_int(1));
    if (d.column_text(2) == "queue_overflow") overflowed += std::uint64_t(d.column_int(1));
  }
  // A 2 s stall at ~125 Hz with a queue of 16: ~230 frames have no room. At least 80 even if the
  // pseudo-terminal delivered at half its rate (CI's loaded run once had 75 lost in a 1 s stall: the
  // tty had delivered ~91 frames in it, not 125).
  EXPECT_GE(overflowed, 80u) << "a 2 s stall at ~125 Hz with a queue of 16";
  // The index fell behind: its rows waited (some on disk) and none was lost.
  EXPECT_EQ(scalar(db, "SELECT count(*) FROM events WHERE kind = 'index_overflow'"), 0);
  auto e = db.prepare("SELECT message FROM events WHERE kind = 'index_behind'");
  ASSERT_TRUE(e.step()) << "no index_behind event";
  const std::string behind = e.column_text(0);
  std::printf("%s\nsensel: %llu frames lost to its queue\n", behind.c_str(), (unsigned long long)overflowed);
  EXPECT_NE(behind.find("none was lost"), std::string::npos) << behind;
  const auto on_disk = behind.find(" of them on disk");
  ASSERT_NE(on_disk, std::string::npos) << behind;
  EXPECT_GT(std::stoull(behind.substr(behind.rfind('(', on_disk) + 1)), 0u) << "the overflow's memory holds 50 rows";
  const auto span = std::uint64_t(*stored.rbegin() - *stored.begin() + 1);
  EXPECT_EQ(stored.size() + dropped, span)
      << "every pressure frame from the first to the last stored is a row or a drop";
  // Every camera frame received is a row: each camera's sequences from its first row to its last.
  auto f = db.prepare(
      "SELECT device_id, connection, count(*), max(sequence) - min(sequence) + 1 FROM frames GROUP BY device_id, "
      "connection");
  int cameras = 0;
  while (f.step()) {
    ++cameras;
    const std::int64_t rows = f.column_int(2), span_frames = f.column_int(3);
    const std::int64_t drops = scalar(db, fmt::format("SELECT coalesce(sum(count), 0) FROM drops WHERE device_id = {} "
                                                      "AND connection = {}",
                                                      f.column_int(0), f.column_int(1)));
    EXPECT_EQ(rows + drops, span_frames) << "camera device " << f.column_int(0);
  }
  EXPECT_GT(cameras, 0);
  EXPECT_FALSE(fs::exists(session / "spill" / "index-rows.overflow")) << "read back and removed";
}

// The Morph over libusb in a whole session: the simulator serves it on umockdev's emulated USB bus
// (`sim: {sensel: {transport: usb}}`) and pvcap starts itself again under umockdev's preload library
// to see it. Pressure is recorded from the Morph "on usb", and `pvcap devices` run beside the session
// names that Morph as in use and leaves it alone. (The suite's other sessions use the pseudo-terminal:
// docs/testing.md says why.)
TEST(SessionFaults, AMorphOnTheUsbBusIsRecordedOverLibusbAndNamedAsInUse) {
  const fs::path work = work_dir("usb-morph");
  std::string yaml = sim_rig_yaml({{}, {}}, 320, 240, 30, 15, "free-run", /*sensel=*/true);
  const std::string from = "sensel: {press_x_mm";
  const auto at = yaml.find(from);
  ASSERT_NE(at, std::string::npos);
  yaml.replace(at, from.size(), "sensel: {transport: usb, press_x_mm");
  std::ofstream(work / "rig.yaml") << yaml;
  const fs::path root = work / "sessions", log = work / "session.log";
  const pid_t pid = spawn_pvcap(
      fmt::format("session --rig {} --root {} --duration 60 --no-web", (work / "rig.yaml").string(), root.string()),
      log);
  ASSERT_TRUE(wait_for_text(log, " s | cam0", std::chrono::seconds(60))) << read_all(log);
  const fs::path usb = root / fmt::format(".sim-truth-{}", pid) / "sensel.usb";
  EXPECT_TRUE(fs::is_symlink(usb)) << usb;
  std::error_code ec;
  const fs::path testbed = fs::read_symlink(usb, ec);
  // On the bus the session sees, from the session's own network namespace.
  const auto listed = run_pvcap(
      "devices", fmt::format("nsenter --net=/proc/{}/ns/net env LD_PRELOAD=libumockdev-preload.so.0 UMOCKDEV_DIR={}",
                             pid, testbed.string()));
  EXPECT_EQ(listed.exit_code, 0) << listed.output;
  EXPECT_NE(listed.output.find("over USB: in use by another program, such as a running pvcap session (not touched)"),
            std::string::npos)
      << listed.output;
  ASSERT_EQ(kill(pid, SIGINT), 0);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  const std::string said = read_all(log);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << said;
  EXPECT_NE(said.find(" on usb, grid 47x27"), std::string::npos) << said;
  const fs::path session = only_session(root);
  ASSERT_FALSE(session.empty()) << said;
  pvcap::sqlite::Database db(session / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
  EXPECT_GT(scalar(db, "SELECT count(*) FROM pressure_frames"), 200) << "about 2 s or more at ~125 Hz";
}

// An ssh connection that drops (SIGHUP) and a service manager's stop (SIGTERM) end the session like
// Ctrl-C: stopped by the operator, everything closed, exit 0. (And `pvcap devices` run beside a
// session does not touch its Morph.)
TEST(SessionFaults, SighupAndSigtermStopTheSessionCleanly) {
  const fs::path work = work_dir("signals");
  const fs::path rig = write_rig(work);
  for (const int sig : {SIGHUP, SIGTERM}) {
    const fs::path root = work / fmt::format("sig{}", sig);
    const fs::path log = work / fmt::format("sig{}.log", sig);
    const pid_t pid =
        spawn_pvcap(fmt::format("session --rig {} --root {} --duration 60 --no-web", rig.string(), root.string()), log);
    // The first status line (about 2 s in; "2.1 s" on a loaded machine).
    ASSERT_TRUE(wait_for_text(log, " s | cam0", std::chrono::seconds(60))) << read_all(log);
    if (sig == SIGHUP) {
      // Meanwhile `pvcap devices` asked about the Morph the session streams from leaves it alone.
      const fs::path tty = root / fmt::format(".sim-truth-{}", pid) / "sensel.tty";
      ASSERT_TRUE(fs::exists(tty)) << tty;
      // In the session's own network namespace: its camera discovery stays off the host's network.
      const auto listed = run_pvcap("devices --tty " + tty.string(), fmt::format("nsenter --net=/proc/{}/ns/net", pid));
      EXPECT_EQ(listed.exit_code, 0) << listed.output;
      EXPECT_NE(listed.output.find("in use by a running pvcap session (not touched)"), std::string::npos)
          << listed.output;
    }
    ASSERT_EQ(kill(pid, sig), 0);
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << strsignal(sig) << ": " << read_all(log);
    const fs::path session = only_session(root);
    ASSERT_FALSE(session.empty());
    pvcap::sqlite::Database db(session / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
    auto q = db.prepare("SELECT coalesce(end_reason, '') FROM session");
    ASSERT_TRUE(q.step());
    EXPECT_EQ(q.column_text(0), "stopped by operator") << strsignal(sig);
    const auto v = run_pvcap("verify " + session.string());
    EXPECT_EQ(v.exit_code, 0) << strsignal(sig) << ": " << v.output;
    if (v.exit_code != 0) {  // where a sample without pressure lies against the pressure recorded
      auto u = db.prepare(
          "SELECT s.id, (SELECT count(*) FROM samples), s.t_ns - (SELECT min(host_ns) FROM pressure_frames), "
          "s.t_ns - (SELECT max(host_ns) FROM pressure_frames), coalesce(s.before_offset_ns, 0), "
          "coalesce(s.after_offset_ns, 0) FROM samples s WHERE s.pressure_sequence IS NULL");
      while (u.step())
        std::printf(
            "sample %lld of %lld without pressure: %.1f ms after the first pressure frame, %.1f ms after the "
            "last; before %.1f ms, after %.1f ms\n",
            static_cast<long long>(u.column_int(0)), static_cast<long long>(u.column_int(1)),
            double(u.column_int(2)) / 1e6, double(u.column_int(3)) / 1e6, double(u.column_int(4)) / 1e6,
            double(u.column_int(5)) / 1e6);
    }
    EXPECT_EQ(scalar(db, "SELECT count(*) FROM events WHERE kind LIKE 'sensel_%'"), 0)
        << "the Morph streamed on, untouched by the listing";
  }
}

// A session started with hang-ups ignored (`nohup pvcap session ...`) keeps recording through one:
// the user asked it to outlive the terminal. Ctrl-C still stops it cleanly.
TEST(SessionFaults, ASessionStartedWithNohupIgnoresHangups) {
  const fs::path work = work_dir("nohup");
  const fs::path rig = write_rig(work);
  const fs::path root = work / "sessions", log = work / "pvcap.log";
  const pid_t pid = spawn_pvcap(
      fmt::format("session --rig {} --root {} --duration 60 --no-web", rig.string(), root.string()), log, "nohup");
  ASSERT_TRUE(wait_for_text(log, " s | cam0", std::chrono::seconds(60))) << read_all(log);
  EXPECT_NE(read_all(log).find("hang-ups are ignored, as the caller asked (nohup)"), std::string::npos);
  ASSERT_EQ(kill(pid, SIGHUP), 0);
  std::this_thread::sleep_for(std::chrono::seconds(3));
  int status = 0;
  EXPECT_EQ(waitpid(pid, &status, WNOHANG), 0) << "still recording 3 s after the hang-up: " << read_all(log);
  ASSERT_EQ(kill(pid, SIGINT), 0);
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << read_all(log);
  const fs::path session = only_session(root);
  ASSERT_FALSE(session.empty());
  pvcap::sqlite::Database db(session / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
  auto q = db.prepare("SELECT coalesce(end_reason, '') FROM session");
  ASSERT_TRUE(q.step());
  EXPECT_EQ(q.column_text(0), "stopped by operator");
}

// The operator's ssh connection drops, as it really happens: `pvcap session` runs as the job of an
// interactive bash on a pseudo-terminal, writing to it, and the terminal is closed (no kill() of
// ours). The kernel hangs up the job, bash forwards a second hang-up, and writes to the dead
// terminal fail: the session still stops cleanly, writes its report, verifies, and exits 0.
TEST(SessionFaults, ClosingTheTerminalOfAnInteractiveShellStopsTheSessionCleanly) {
  const fs::path work = work_dir("hangup");
  const fs::path rig = write_rig(work);
  const fs::path root = work / "sessions", status_file = work / "status";
  int master = -1;
  const pid_t shell = forkpty(&master, nullptr, nullptr, nullptr);
  ASSERT_GE(shell, 0) << std::strerror(errno);
  if (shell == 0) {
    execl("/bin/bash", "bash", "--norc", "--noprofile", "-i", static_cast<char*>(nullptr));
    _exit(127);
  }
  // The wrapper only keeps the exit status (it catches the hang-up itself with a no-op: a caught
  // signal is back to its default in pvcap, where an ignored one would stay ignored, as nohup asks);
  // pvcap sets its own handlers, and its output goes to the terminal.
  const std::string line =
      fmt::format("sh -c 'trap : HUP; {} session --rig {} --root {} --duration 60 --no-web; echo $? > {}'\n", PVCAP_BIN,
                  rig.string(), root.string(), status_file.string());
  ASSERT_EQ(write(master, line.data(), line.size()), ssize_t(line.size()));
  // Read the terminal as a terminal emulator would (a full pty would block the writer) until six
  // seconds of recording were shown.
  std::string shown;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(90);
  while (recorded_seconds_shown(shown) < 6.0 && std::chrono::steady_clock::now() < deadline) {
    pollfd p{master, POLLIN, 0};
    if (poll(&p, 1, 200) <= 0) continue;
    char buf[4096];
    const ssize_t n = read(master, buf, sizeof buf);
    if (n <= 0) break;
    shown.append(buf, std::size_t(n));
  }
  ASSERT_GE(recorded_seconds_shown(shown), 6.0) << shown;
  close(master);  // the terminal window closes
  int shell_status = 0;
  waitpid(shell, &shell_status, 0);
  for (int i = 0; i < 600 && !fs::exists(status_file); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ASSERT_TRUE(fs::exists(status_file)) << "pvcap did not end within 60 s of the hang-up";
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // the echo's line complete
  EXPECT_EQ(read_all(status_file), "0\n") << "pvcap's exit status after the hang-up";
  const fs::path session = only_session(root);
  ASSERT_FALSE(session.empty());
  EXPECT_TRUE(fs::exists(session / "report.html"));
  EXPECT_FALSE(fs::exists(session / "space-reserve")) << "the space reserve is given back";
  {
    pvcap::sqlite::Database db(session / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
    auto q = db.prepare("SELECT coalesce(end_reason, '') FROM session");
    ASSERT_TRUE(q.step());
    EXPECT_EQ(q.column_text(0), "stopped by operator");
  }
  const auto v = run_pvcap("verify " + session.string());
  EXPECT_EQ(v.exit_code, 0) << v.output << why_sample_frames_are_not_in_a_video(session);
}

// A participant's session is for the lab, not for every user of the machine: run as root (as the
// simulated rig needs), its folder is 0750 and its files 0640; with store.group the folder is that
// group's (setgid) and its members read it, and another user reads nothing.
TEST(SessionFaults, ASessionIsReadableByItsGroupAndByNoOtherUser) {
  const fs::path work = work_dir("permissions");
  const group* users = getgrnam("users");
  ASSERT_NE(users, nullptr) << "Debian's 'users' group";
  const gid_t users_gid = users->gr_gid;
  std::string rig = sim_rig_yaml({{}}, 320, 240, 30, 15, "free-run", /*sensel=*/true);
  const std::string at = "  preset: ultrafast\n";
  ASSERT_NE(rig.find(at), std::string::npos);
  rig.replace(rig.find(at), at.size(), at + "  group: users\n");
  std::ofstream(work / "rig.yaml") << rig;
  fs::create_directories(work / "sessions");
  fs::permissions(work / "sessions", fs::perms(0755));  // a lab's sessions root, made by its admin
  const auto r = run_pvcap(fmt::format("session --rig {} --root {} --duration 2 --no-web", (work / "rig.yaml").string(),
                                       (work / "sessions").string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const fs::path session = only_session(work / "sessions");
  ASSERT_FALSE(session.empty());
  struct stat st {};
  ASSERT_EQ(stat(session.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 02750u) << std::oct << (st.st_mode & 07777);
  EXPECT_EQ(st.st_gid, users_gid);
  for (const char* file : {"session.db", "cam0-000.mkv", "report.html", "report.txt"}) {
    ASSERT_EQ(stat((session / file).c_str(), &st), 0) << file;
    EXPECT_EQ(st.st_mode & 0777, 0640u) << file << ": " << std::oct << (st.st_mode & 0777);
    EXPECT_EQ(st.st_gid, users_gid) << file;
  }
  auto read_as = [&](gid_t gid) {
    return std::system(fmt::format("setpriv --reuid=65534 --regid={} --clear-groups cat {} > /dev/null 2>&1", gid,
                                   (session / "session.db").string())
                           .c_str());
  };
  EXPECT_NE(read_as(65534), 0) << "another user (nobody) read the index";
  EXPECT_EQ(read_as(users_gid), 0) << "a member of the lab's group could not read the index";

  // A group the machine does not have: named, before anything is recorded.
  rig.replace(rig.find("  group: users\n"), std::string("  group: users\n").size(), "  group: no-such-lab\n");
  std::ofstream(work / "rig.yaml") << rig;
  const auto refused = run_pvcap(fmt::format("session --rig {} --root {} --duration 2 --no-web",
                                             (work / "rig.yaml").string(), (work / "other").string()));
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_NE(refused.output.find("there is no group 'no-such-lab'"), std::string::npos) << refused.output;
}
