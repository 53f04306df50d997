// `pvcap verify` on a real recording of the simulated rig, then on damaged copies of it.
#include <gtest/gtest.h>

#include <sys/resource.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>

#include "storage/index/database.h"
#include "storage/index/session_reader.h"
#include "storage/video/video_reader.h"
#include "storage/video/video_writer.h"
#include "tests/integration/session_under_test.h"

namespace fs = std::filesystem;
using pvcap::testing::record;
using pvcap::testing::run_pvcap;
using pvcap::testing::sim_rig_yaml;

TEST(Verify, ARecordingVerifiesAndDamageIsNamed) {
  const auto s = record("verify", sim_rig_yaml({{}, {}}, 640, 480, 30, 15, "free-run", /*sensel=*/true), 5);
  ASSERT_EQ(s.result.exit_code, 0) << s.result.output;

  auto ok = run_pvcap(fmt::format("--log-level warn verify {}", s.dir.string()));
  EXPECT_TRUE(ok.exit_code == 0 || ok.exit_code == 3) << ok.output;  // 3: a frame lost on a busy machine
  EXPECT_NE(ok.output.find("cam0-000.mkv:"), std::string::npos) << ok.output;
  EXPECT_NE(ok.output.find("pressure frames:"), std::string::npos) << ok.output;
  EXPECT_EQ(ok.output.find("ERROR"), std::string::npos) << ok.output;
  // Work on finished sessions yields to a recording on the same machine (nice 10, or this test's own
  // when it is lower); a command that does not stays at this test's priority.
  const int own = getpriority(PRIO_PROCESS, 0);
  auto niced = run_pvcap(fmt::format("--log-level debug verify {}", s.dir.string()));
  EXPECT_NE(niced.output.find(fmt::format("pvcap verify: at nice {}", std::max(own, 10))), std::string::npos)
      << niced.output;
  auto sensel = run_pvcap(fmt::format("--log-level debug sensel decode {}", (s.dir / "session.db").string()));
  EXPECT_NE(sensel.output.find(fmt::format("pvcap sensel: at nice {}", own)), std::string::npos) << sensel.output;

  // A video cut short after a clean end: indexed frames are missing, named with the file.
  const auto copy = s.dir.parent_path() / "damaged";
  fs::copy(s.dir, copy, fs::copy_options::recursive | fs::copy_options::copy_symlinks);
  const auto video = copy / "cam1-000.mkv";
  fs::resize_file(video, fs::file_size(video) / 2);
  auto cut = run_pvcap(fmt::format("--log-level warn verify {}", copy.string()));
  EXPECT_EQ(cut.exit_code, 1) << cut.output;
  EXPECT_NE(cut.output.find("ERROR: cam1-000.mkv"), std::string::npos) << cut.output;

  // A foreign file where the index should be.
  std::ofstream(copy / "session.db", std::ios::trunc) << "this is not a database, it is a shopping list\n";
  auto foreign = run_pvcap(fmt::format("--log-level warn verify {}", copy.string()));
  EXPECT_EQ(foreign.exit_code, 1) << foreign.output;
  EXPECT_NE(foreign.output.find("session.db"), std::string::npos) << foreign.output;

  // Not a session folder at all.
  fs::remove(copy / "session.db");
  auto none = run_pvcap(fmt::format("--log-level warn verify {}", copy.string()));
  EXPECT_EQ(none.exit_code, 1) << none.output;
  EXPECT_NE(none.output.find("not a session folder"), std::string::npos) << none.output;
}

namespace {

// Rewrites a raw video as a re-mux or a bug in the encode path would: a structurally valid file
// (same codec, frames, timestamps, fresh container checksums) whose frame `altered` differs from
// what the camera sent by one bit of one pixel.
void rewrite_with_one_frame_altered(const fs::path& video, std::size_t altered) {
  std::vector<std::int64_t> pts;
  {
    auto r = pvcap::VideoReader::open(video);
    ASSERT_TRUE(r) << r.error().message;
    std::int64_t ms = 0;
    bool key = false;
    for (auto more = r.value()->next_packet(ms, key); more && more.value(); more = r.value()->next_packet(ms, key))
      pts.push_back(ms);
  }
  ASSERT_GT(pts.size(), altered);
  auto reader = pvcap::VideoReader::open(video);
  ASSERT_TRUE(reader) << reader.error().message;
  pvcap::VideoSettings settings;
  settings.bayer_format = reader.value()->bayer_format();
  ASSERT_FALSE(settings.bayer_format.empty()) << "the default store is raw";
  settings.width = reader.value()->width();
  settings.height = reader.value()->height();
  const fs::path out = video.string() + ".new.mkv";
  auto writer = pvcap::VideoWriter::open(out, settings);
  ASSERT_TRUE(writer) << writer.error().message;
  cv::Mat mosaic;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    auto found = reader.value()->read_raw_at(pts[i], mosaic, 0);
    ASSERT_TRUE(found && found.value()) << "frame " << i;
    if (i == altered) mosaic.at<std::uint8_t>(7, 9) ^= 1;
    ASSERT_TRUE(writer.value()->write(mosaic, pts[i] * 1000));
  }
  ASSERT_TRUE(writer.value()->close().ok());
  fs::rename(out, video);
}

}  // namespace

// Damage no container check sees: a frame of a structurally valid segment differs from the
// camera's bytes, and a pressure payload in the index differs from the Sensel's. Verify decodes
// every frame, checks it against the checksum taken at capture, and names each damaged one.
TEST(Verify, AFrameAlteredInsideAValidSegmentIsNamed) {
  const auto s = record("verify-checksum", sim_rig_yaml({{}}, 320, 240, 30, 15, "free-run", /*sensel=*/true), 4);
  ASSERT_EQ(s.result.exit_code, 0) << s.result.output;
  auto ok = run_pvcap(fmt::format("--log-level warn verify {}", s.dir.string()));
  EXPECT_NE(ok.output.find("checked against their capture checksum, 0 damaged"), std::string::npos) << ok.output;
  EXPECT_NE(ok.output.find("the session lasted"), std::string::npos) << ok.output;

  rewrite_with_one_frame_altered(s.dir / "cam0-000.mkv", 30);
  {
    pvcap::sqlite::Database db(s.dir / "session.db", pvcap::sqlite::Database::Mode::ReadWrite);
    auto q = db.prepare("SELECT rowid, payload FROM pressure_frames ORDER BY rowid LIMIT 1 OFFSET 40");
    ASSERT_TRUE(q.step());
    const std::int64_t row = q.column_int(0);
    auto payload = q.column_blob(1);
    ASSERT_FALSE(payload.empty());
    payload[payload.size() / 2] ^= 0x10;
    auto u = db.prepare("UPDATE pressure_frames SET payload = ? WHERE rowid = ?");
    u.bind_all(payload, row);
    u.step();
  }
  auto damaged = run_pvcap(fmt::format("--log-level warn verify {}", s.dir.string()));
  EXPECT_EQ(damaged.exit_code, 1) << damaged.output;
  EXPECT_NE(damaged.output.find("ERROR: cam0-000.mkv: frame 30 (cam0"), std::string::npos) << damaged.output;
  EXPECT_NE(damaged.output.find("not the bytes the camera sent"), std::string::npos) << damaged.output;
  EXPECT_NE(damaged.output.find("1 damaged"), std::string::npos) << damaged.output;
  EXPECT_NE(damaged.output.find("its payload is not the bytes the Sensel sent"), std::string::npos) << damaged.output;
  std::printf("%s", damaged.output.c_str());

  // The reader, asked to check, refuses that one frame and hands out every other.
  auto reader = pvcap::SessionReader::open(s.dir);
  ASSERT_TRUE(reader) << reader.error().message;
  reader.value()->set_check_checksums(true);
  std::size_t refused = 0, read = 0;
  for (std::size_t i = 0; i < reader.value()->sample_count(); ++i) {
    auto image = reader.value()->raw_image(i, 0);
    if (image)
      ++read;
    else if (image.error().message.find("not the bytes the camera sent") != std::string::npos)
      ++refused;
  }
  EXPECT_EQ(refused, 1u);
  EXPECT_GT(read, 40u);
}
