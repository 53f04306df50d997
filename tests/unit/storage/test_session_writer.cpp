#include <gtest/gtest.h>

#include <sys/resource.h>

#include <csignal>
#include <filesystem>

#include "core/rig_config.h"
#include "core/time.h"
#include "storage/session_index.h"
#include "storage/session_writer.h"

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
