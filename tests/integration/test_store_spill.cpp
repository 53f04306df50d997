// Raw video and the spill through real `pvcap session`s on the simulated rig: an encoder that falls
// behind (a CPU hog) loses no frame, and a drain killed half way is finished by `pvcap recover`
// with every spilled frame in a video, bit for bit.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <thread>

#include <fmt/format.h>

#include "storage/index/database.h"
#include "storage/index/video_repair.h"
#include "storage/video/video_reader.h"
#include "storage/video/view_video.h"
#include "storage/writer/frame_spill.h"
#include "tests/integration/session_under_test.h"

namespace fs = std::filesystem;
using pvcap::testing::only_session;
using pvcap::testing::read_all;
using pvcap::testing::run_pvcap;
using pvcap::testing::sim_rig_yaml;
using pvcap::testing::spawn_pvcap;
using pvcap::testing::wait_for_text;
using pvcap::testing::work_dir;
using namespace std::chrono_literals;

namespace {

// The rig's store section with its `preset: ultrafast` line replaced by `lines` (these tests set
// their own preset and codec; test_store_failures' with_store appends instead).
std::string store_lines_instead_of_preset(std::string yaml, const std::string& lines) {
  const std::string at = "  preset: ultrafast\n";
  yaml.replace(yaml.find(at), at.size(), lines);
  return yaml;
}

std::int64_t count(pvcap::sqlite::Database& db, const std::string& sql) {
  auto q = db.prepare(sql);
  return q.step() ? q.column_int(0) : -1;
}

std::string text(pvcap::sqlite::Database& db, const std::string& sql) {
  auto q = db.prepare(sql);
  return q.step() && !q.column_null(0) ? q.column_text(0) : "";
}

// A busy loop on one core for as long as it lives.
struct CpuHog {
  pid_t pid = fork();
  CpuHog() {
    if (pid == 0) execl("/bin/sh", "sh", "-c", "while :; do :; done", static_cast<char*>(nullptr));
  }
  ~CpuHog() {
    kill(pid, SIGKILL);
    waitpid(pid, nullptr, 0);
  }
};

}  // namespace

// Four 1080p cameras in raw mode with another process taking one of the two cores. At the defaults
// (15 Hz, ffvhuff) the encoders keep up even beside the hog and the spill stays unused (seen in the
// suite), so here every frame is kept (video_fps 0: 4 x 30 frames/s), the raw codec is lossless
// x264 with a memory queue of two frames, and each encoder waits 40 ms before every frame (a fault,
// core/fault_injection.h: at most 25 of 30 frames/s on any machine): the encoders fall behind,
// frames wait in the spill, and none is dropped.
TEST(StoreSpill, ABusyMachineLosesNoFrameToTheEncoder) {
  const fs::path work = work_dir("spill-hog");
  std::ofstream(work / "rig.yaml") << store_lines_instead_of_preset(
      sim_rig_yaml({{}, {}, {}, {}}, 1920, 1080, 30, 0, "free-run", /*sensel=*/true),
      "  preset: ultrafast\n  raw_codec: libx264\n  queue_frames: 2\n");
  pvcap::testing::CommandResult result;
  {
    CpuHog hog;
    setenv("PVCAP_FAULTS", "encoder.frame_delay_ms=40", 1);
    result = run_pvcap(fmt::format("session --rig {} --root {} --duration 6 --no-web", (work / "rig.yaml").string(),
                                   (work / "sessions").string()));
    unsetenv("PVCAP_FAULTS");
  }
  ASSERT_EQ(result.exit_code, 0) << result.output;
  const fs::path dir = only_session(work / "sessions");
  ASSERT_FALSE(dir.empty());
  {
    pvcap::sqlite::Database db(dir / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
    EXPECT_EQ(count(db, "SELECT count(*) FROM frames WHERE reason = 'encoder_behind'"), 0) << result.output;
    EXPECT_EQ(count(db, "SELECT count(*) FROM frames WHERE reason LIKE 'spill%'"), 0);
    EXPECT_EQ(count(db, "SELECT count(*) FROM video_files WHERE layout != 'bayer_planes_green_last'"), 0)
        << "Bayer cameras are stored raw by default, the second green last";
    const std::int64_t spill_events = count(db, "SELECT count(*) FROM events WHERE kind = 'spill'");
    EXPECT_GT(spill_events, 0) << "the spill was used: " << result.output;
    auto q = db.prepare("SELECT message FROM events WHERE kind = 'spill'");
    while (q.step()) std::printf("%s\n", q.column_text(0).c_str());
    // Every kept frame the samples name is in a video.
    EXPECT_EQ(count(db,
                    "SELECT count(*) FROM sample_frames sf JOIN frames f USING (device_id, connection, sequence) "
                    "WHERE f.kept = 0"),
              0)
        << text(db,
                "SELECT group_concat(f.reason) FROM sample_frames sf JOIN frames f USING "
                "(device_id, connection, sequence) WHERE f.kept = 0");
  }
  EXPECT_FALSE(fs::exists(dir / pvcap::kSpillFolder)) << "a drained spill leaves nothing behind";
  {
    // An encoder behind skips the view copies (storage/video/view_video.h): fewer frames in the view videos
    // than in the lossless ones, whose every frame the replay then reads instead.
    pvcap::sqlite::Database db(dir / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
    const std::int64_t kept = count(db, "SELECT count(*) FROM frames WHERE kept = 1");
    std::int64_t in_views = 0;
    auto q = db.prepare("SELECT path FROM video_files");
    while (q.step()) {
      const fs::path view = dir / pvcap::view_video_path(q.column_text(0));
      ASSERT_TRUE(fs::exists(view)) << view;
      auto frames = pvcap::count_video_frames(view);
      ASSERT_TRUE(frames) << frames.error().message;
      in_views += frames.value();
    }
    std::printf("%lld of %lld kept frames in the view videos\n", static_cast<long long>(in_views),
                static_cast<long long>(kept));
    EXPECT_LT(in_views, kept);
  }
  // The videos and the index agree frame for frame. (Under the hog the Sensel's stream may leave an
  // edge sample without pressure, which verify reports as lossy: not the video's doing.)
  const auto verified = run_pvcap(fmt::format("--log-level off verify {}", dir.string()));
  EXPECT_TRUE(verified.exit_code == 0 || verified.exit_code == 3) << verified.output;
  EXPECT_EQ(verified.output.find("ERROR"), std::string::npos) << verified.output;
  EXPECT_EQ(verified.output.find("not encoded in time"), std::string::npos) << verified.output;
  EXPECT_EQ(verified.output.find("never reached"), std::string::npos) << verified.output;
}

// The encoder far behind (every frame kept, and each encoder waits 100 ms before every frame, a fault
// of core/fault_injection.h: 10 of the camera's 30 frames/s on any machine), the session stopped,
// and the process killed while it drains the spill: `pvcap recover` encodes what the spill
// still holds, and every spilled frame ends in a video exactly as the camera sent it.
TEST(StoreSpill, KillDuringTheDrainThenRecoverPutsEverySpilledFrameInAVideo) {
  const fs::path work = work_dir("spill-kill");
  std::ofstream(work / "rig.yaml") << store_lines_instead_of_preset(
      sim_rig_yaml({{}, {}, {}, {}}, 640, 480, 30, 0, "free-run", /*sensel=*/true),
      "  raw_codec: libx264\n  preset: ultrafast\n  queue_frames: 4\n");
  setenv("PVCAP_FAULTS", "encoder.frame_delay_ms=100", 1);
  const pid_t pid = spawn_pvcap(fmt::format("session --rig {} --root {} --duration 6 --no-web",
                                            (work / "rig.yaml").string(), (work / "sessions").string()),
                                work / "log.txt");
  unsetenv("PVCAP_FAULTS");
  ASSERT_TRUE(wait_for_text(work / "log.txt", "encoding the frames still waiting", 60s)) << read_all(work / "log.txt");
  std::this_thread::sleep_for(500ms);
  ASSERT_EQ(kill(pid, SIGKILL), 0);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << read_all(work / "log.txt");
  const fs::path dir = only_session(work / "sessions");
  ASSERT_FALSE(dir.empty());

  // What the spill holds at the kill, frame by frame.
  std::map<std::tuple<std::int64_t, std::uint32_t, std::uint64_t>, cv::Mat> spilled;
  ASSERT_TRUE(fs::is_directory(dir / pvcap::kSpillFolder)) << read_all(work / "log.txt");
  for (const auto& e : fs::directory_iterator(dir / pvcap::kSpillFolder)) {
    if (e.path().extension() != ".spill") continue;  // the index's journal lives there too
    auto n = pvcap::read_spill_file(e.path(), [&](pvcap::SpillRecord&& r) {
      spilled[{r.rec.device_id, r.rec.connection, r.rec.sequence}] = r.image;
    });
    ASSERT_TRUE(n) << n.error().message;
  }
  ASSERT_GT(spilled.size(), 20u) << "the kill came while frames were still waiting";
  const auto before = run_pvcap(fmt::format("--log-level off verify {}", dir.string()));
  EXPECT_NE(before.output.find("spill file(s) hold frames"), std::string::npos) << before.output;

  const auto recovered = run_pvcap(fmt::format("--log-level warn recover {}", dir.string()));
  ASSERT_EQ(recovered.exit_code, 0) << recovered.output;
  EXPECT_NE(recovered.output.find("spilled frames encoded"), std::string::npos) << recovered.output;
  EXPECT_FALSE(fs::exists(dir / pvcap::kSpillFolder)) << recovered.output;

  // Every spilled frame: a kept row, and in its video the very pixels the camera sent.
  pvcap::sqlite::Database db(dir / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
  std::map<std::string, std::unique_ptr<pvcap::VideoReader>> videos;
  std::size_t exact = 0;
  for (const auto& [key, image] : spilled) {
    const auto& [device, connection, sequence] = key;
    auto q = db.prepare(
        "SELECT f.kept, v.path, f.video_pts_ms FROM frames f LEFT JOIN video_files v ON v.id = f.video_file_id "
        "WHERE f.device_id = ? AND f.connection = ? AND f.sequence = ?");
    q.bind_all(device, std::int64_t(connection), std::int64_t(sequence));
    ASSERT_TRUE(q.step()) << "no row for spilled frame " << sequence << " of device " << device;
    ASSERT_EQ(q.column_int(0), 1) << "spilled frame " << sequence << " of device " << device << " is not in a video";
    const std::string path = q.column_text(1);
    const std::int64_t pts = q.column_int(2);
    auto& reader = videos[path];
    if (!reader) {
      auto opened = pvcap::VideoReader::open(dir / path);
      ASSERT_TRUE(opened) << opened.error().message;
      reader = std::move(opened.value());
    }
    cv::Mat mosaic;
    auto found = reader->read_raw_at(pts, mosaic, 0);
    ASSERT_TRUE(found && found.value()) << path << " at " << pts << " ms";
    exact += cv::norm(mosaic, image, cv::NORM_INF) == 0;
  }
  EXPECT_EQ(exact, spilled.size()) << "every spilled frame bit-exact in its video";
  std::printf("%zu frames were in the spill at the kill; recover said:\n%s", spilled.size(), recovered.output.c_str());
  // A second recover finds nothing more to do with spills.
  const auto again = run_pvcap(fmt::format("--log-level warn recover {}", dir.string()));
  EXPECT_EQ(again.exit_code, 0) << again.output;
  EXPECT_EQ(again.output.find("spilled frames encoded"), std::string::npos) << again.output;
}
