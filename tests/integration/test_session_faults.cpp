// Faults of a running session met through the real `pvcap session` on the simulated rig: a second
// recorder on the same rig, and a --root that cannot take a session (read-only, missing parent).
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/mount.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>

#include <fmt/format.h>

#include "session_under_test.h"

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

}  // namespace

TEST(SessionFaults, ASecondRecorderOnTheSameRigIsRefusedWithTheRunningOnesPidAndFolder) {
  const fs::path work = work_dir("one-recorder");
  const fs::path rig = write_rig(work);
  const pid_t first = spawn_pvcap(fmt::format("session --rig {} --root {} --duration 12 --no-web", rig.string(),
                                              (work / "first").string()),
                                  work / "first.log");
  ASSERT_TRUE(wait_for_text(work / "first.log", "recording session", std::chrono::seconds(60)))
      << read_all(work / "first.log");
  const auto second = run_pvcap(fmt::format("session --rig {} --root {} --duration 3 --no-web", rig.string(),
                                            (work / "second").string()));
  int status = 0;
  ASSERT_EQ(waitpid(first, &status, 0), first);
  const auto running = sessions_in(work / "first");
  ASSERT_EQ(running.size(), 1u);
  EXPECT_EQ(second.exit_code, 1) << second.output;
  EXPECT_NE(second.output.find("is already recording"), std::string::npos) << second.output;
  EXPECT_NE(second.output.find(fmt::format("pid {}", first)), std::string::npos) << second.output;
  EXPECT_NE(second.output.find(running[0].string()), std::string::npos) << "names the running session's folder: "
                                                                         << second.output;
  EXPECT_TRUE(sessions_in(work / "second").empty()) << "the refused recorder left no session behind";
  // The first session never noticed.
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << read_all(work / "first.log");
  const auto v = run_pvcap("verify " + running[0].string());
  EXPECT_TRUE(v.exit_code == 0 || v.exit_code == 3) << v.output;
  // Once it has ended, the rig is free again (also after a kill: the kernel drops the lock).
  const auto third = run_pvcap(fmt::format("session --rig {} --root {} --duration 2 --no-web", rig.string(),
                                           (work / "third").string()));
  EXPECT_EQ(third.exit_code, 0) << third.output;
  fs::remove_all(work);
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
  const auto ro = run_pvcap(fmt::format("session --rig {} --root {} --duration 2 --no-web", rig.string(),
                                        readonly.string()));
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
  fs::remove_all(work);
}
