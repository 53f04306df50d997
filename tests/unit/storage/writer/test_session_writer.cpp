#include <gtest/gtest.h>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>

#include "core/rig_config.h"
#include "core/time.h"
#include "storage/index/session_index.h"
#include "storage/writer/session_writer.h"

namespace fs = std::filesystem;
using namespace pvcap;

TEST(SessionWriter, NeverReusesASessionFolder) {
  const auto root = fs::temp_directory_path() / ("pvcap-test-sw-" + std::to_string(::getpid()));
  fs::remove_all(root);
  const auto rig = parse_rig_config("name: r\ncameras:\n  - address: 10.0.0.1\n", "r.yaml");
  const std::int64_t wall = wall_now_ns(), host = host_now().ns;
  auto a = SessionWriter::create(root, rig, wall, host);
  auto b = SessionWriter::create(root, rig, wall, host);  // same second, same rig
  ASSERT_TRUE(a && b);
  EXPECT_NE(a.value()->dir(), b.value()->dir());
  EXPECT_TRUE(a.value()->close("test").ok());
  EXPECT_TRUE(b.value()->close("test").ok());
  fs::remove_all(root);
}

TEST(SessionWriter, IndexRecordsEveryFrameWithItsReasonAndVersion) {
  const auto root = fs::temp_directory_path() / ("pvcap-test-sw2-" + std::to_string(::getpid()));
  fs::remove_all(root);
  const auto rig = parse_rig_config("name: r\ncameras:\n  - address: 10.0.0.1\n", "r.yaml");
  auto w = SessionWriter::create(root, rig, wall_now_ns(), host_now().ns);
  ASSERT_TRUE(w);
  auto id = w.value()->add_camera(DeviceRecord{"camera", "cam0", "v", "m", "s", "a", "f", "{}"}, 64, 64);
  ASSERT_TRUE(id) << id.error().message;
  w.value()->start();
  const std::int64_t t0 = host_now().ns;
  for (int i = 0; i < 10; ++i) {
    FrameRecord f{
        id.value(), 0, std::uint64_t(i), std::uint64_t(i), i * 1000, t0 + i * 16'666'667, 0, "good", false, "", {}, {}};
    if (i % 4 == 0)
      ASSERT_TRUE(w.value()->submit_video(id.value(), cv::Mat(64, 64, CV_8UC3, cv::Scalar(i, 0, 0)), f));
    else
      w.value()->record(FrameRecord{
          f.device_id, 0, f.sequence, f.frame_id, f.device_ns, f.host_ns, 0, "good", false, "subsampled", {}, {}});
  }
  w.value()->record(DropRecord{id.value(), 0, 10, 3, "not_received", t0});
  const auto dir = w.value()->dir();
  ASSERT_TRUE(w.value()->close("test").ok());

  sqlite::Database db(dir / "session.db", sqlite::Database::Mode::ReadOnly);
  EXPECT_EQ(db.user_version(), kSchemaVersion);
  auto q = db.prepare("SELECT count(*), sum(kept), sum(reason = 'subsampled'), max(video_index) FROM frames");
  ASSERT_TRUE(q.step());
  EXPECT_EQ(q.column_int(0), 10);
  EXPECT_EQ(q.column_int(1), 3);
  EXPECT_EQ(q.column_int(2), 7);
  EXPECT_EQ(q.column_int(3), 2);
  auto d = db.prepare("SELECT first_sequence, count, reason FROM drops");
  ASSERT_TRUE(d.step());
  EXPECT_EQ(d.column_int(1), 3);
  EXPECT_EQ(d.column_text(2), "not_received");
  auto s = db.prepare("SELECT end_reason, ended_host_ns > started_host_ns FROM session");
  ASSERT_TRUE(s.step());
  EXPECT_EQ(s.column_text(0), "test");
  EXPECT_EQ(s.column_int(1), 1);
  fs::remove_all(root);
}

// A start that fails after the session folder was made (here: the space reserve cannot be set
// aside, as when the file-size limit forbids it) says why and leaves no half-made session behind.
TEST(SessionWriter, AFailedStartSaysWhyAndLeavesNoSessionFolder) {
  const auto root = fs::temp_directory_path() / ("pvcap-test-sw3-" + std::to_string(::getpid()));
  fs::remove_all(root);
  fs::create_directories(root);
  const auto rig =
      parse_rig_config("name: r\ncameras:\n  - address: 10.0.0.1\nstore: {min_free_mb: 0, reserve_mb: 8}\n", "r.yaml");
  rlimit old{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old), 0);
  const rlimit one_mb{1 << 20, old.rlim_max};
  auto* previous = std::signal(SIGXFSZ, SIG_IGN);  // the limit's signal would end the test process
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &one_mb), 0);
  auto w = SessionWriter::create(root, rig, wall_now_ns(), host_now().ns);
  setrlimit(RLIMIT_FSIZE, &old);
  std::signal(SIGXFSZ, previous);
  ASSERT_FALSE(w);
  EXPECT_NE(w.error().message.find("space reserve"), std::string::npos) << w.error().message;
  EXPECT_TRUE(fs::is_empty(root)) << "a failed start left " << fs::directory_iterator(root)->path();
  fs::remove_all(root);
}

// A start killed between its hidden folder and the rename leaves `.starting-<name>-<pid>` with an empty
// index: the next start in the sessions folder removes it once its process is gone and it is a
// minute old, and keeps (and names) one that holds anything else.
TEST(SessionWriter, AStartLeftoverOfAKilledProcessIsRemovedAtTheNextStart) {
  const auto root = fs::temp_directory_path() / ("pvcap-test-sw4-" + std::to_string(::getpid()));
  fs::remove_all(root);
  fs::create_directories(root);
  const pid_t child = fork();
  if (child == 0) _exit(0);
  ASSERT_GT(child, 0);
  waitpid(child, nullptr, 0);  // a pid whose process is gone
  const auto old = fs::file_time_type::clock::now() - std::chrono::minutes(2);
  auto leftover = [&](const std::string& tag, pid_t pid, bool is_old, bool recorded) {
    const fs::path dir = root / (".starting-20260101-000000_" + tag + "-" + std::to_string(pid));
    fs::create_directories(dir);
    std::ofstream(dir / "session.db") << "index";
    if (recorded) std::ofstream(dir / "cam0-000.mkv") << "video";
    if (is_old) fs::last_write_time(dir, old);
    return dir;
  };
  const fs::path gone = leftover("gone", child, true, false);
  const fs::path young = leftover("young", child, false, false);
  const fs::path alive = leftover("alive", ::getpid(), true, false);
  const fs::path holds_more = leftover("more", child, true, true);
  const auto rig = parse_rig_config("name: r\ncameras:\n  - address: 10.0.0.1\n", "r.yaml");
  auto w = SessionWriter::create(root, rig, wall_now_ns(), host_now().ns);
  ASSERT_TRUE(w) << w.error().message;
  EXPECT_FALSE(fs::exists(gone)) << "its process gone, a minute old, an index alone";
  EXPECT_TRUE(fs::exists(young)) << "a start may be under way on another machine sharing the folder";
  EXPECT_TRUE(fs::exists(alive)) << "its process is still there";
  EXPECT_TRUE(fs::exists(holds_more / "cam0-000.mkv")) << "more than an index is never removed";
  EXPECT_TRUE(w.value()->close("test").ok());
  fs::remove_all(root);
}
