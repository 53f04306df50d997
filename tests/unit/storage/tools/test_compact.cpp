// `pvcap compact`'s engine on a store written without devices: a raw camera's segments re-encoded
// bit-exact and smaller, an interruption after each step of a replacement leaving a readable
// session that the next run finishes, a damaged frame refused, a live session refused.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "core/rig_config.h"
#include "core/time.h"
#include "sim/scene.h"
#include "storage/index/database.h"
#include "storage/tools/compact.h"
#include "storage/tools/verify.h"
#include "storage/video/frame_checksum.h"
#include "storage/video/video_reader.h"
#include "storage/writer/session_writer.h"

namespace fs = std::filesystem;
using namespace pvcap;

namespace {

fs::path compact_root(const std::string& name) {
  const auto d = fs::temp_directory_path() / ("pvcap-test-compact-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(d);
  return d;
}

// A smooth scene with a moving disc and a little sensor noise, as the sensor's BayerRG8 mosaic:
// what a lossless codec with prediction between frames stores in fewer bytes than an intra one.
cv::Mat scene_mosaic(int i) {
  cv::Mat bgr(96, 128, CV_8UC3);
  for (int y = 0; y < bgr.rows; ++y)
    for (int x = 0; x < bgr.cols; ++x) bgr.at<cv::Vec3b>(y, x) = cv::Vec3b(40 + x, 60 + y, 90 + (x + y) / 2);
  cv::circle(bgr, {20 + 2 * i, 48}, 12, cv::Scalar(200, 180, 160), cv::FILLED);
  cv::Mat noise(bgr.size(), CV_8UC3);
  cv::RNG rng(std::uint64_t(i + 1));
  rng.fill(noise, cv::RNG::UNIFORM, 0, 3);
  bgr += noise;
  return sim::to_sensor_format(bgr, "BayerRG8");
}

// A finished session of one raw camera, `seconds` at 15 Hz in 1-s segments; returns its folder.
// `raw_tiles`: the store's (auto leaves a 128x96 camera in one picture).
fs::path write_raw_session(const fs::path& root, double seconds, const std::string& raw_tiles = "auto") {
  const auto rig = parse_rig_config(
      "name: compact-test\ncameras:\n  - {name: cam0, address: 10.0.0.1}\n"
      "store: {segment_seconds: 1, min_free_mb: 0, reserve_mb: 1, raw_tiles: " + raw_tiles + "}\n",
      "compact-test.yaml");
  const std::int64_t t0 = host_now().ns;
  auto w = SessionWriter::create(root, rig, wall_now_ns(), t0);
  EXPECT_TRUE(w) << w.error().message;
  auto& writer = *w.value();
  auto cam = writer.add_camera(DeviceRecord{"camera", "cam0", "v", "m", "S-0", "a", "f", "{}"}, 128, 96, "BayerRG8");
  EXPECT_TRUE(cam) << cam.error().message;
  EXPECT_TRUE(writer.stores_raw(cam.value()));
  writer.start();
  for (int i = 0; i < int(seconds * 15); ++i) {
    const std::int64_t t = t0 + 10'000'000 + i * 66'666'667;
    cv::Mat mosaic = scene_mosaic(i);
    FrameRecord f{cam.value(), 0, std::uint64_t(i), std::uint64_t(i), i * 1000, t, 0, "good", false, "", {}, {}, t};
    f.checksum = stored_mosaic_crc(mosaic, writer.raw_plane_order(cam.value()));
    EXPECT_TRUE(writer.submit_video(cam.value(), mosaic, f));
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  const fs::path dir = writer.dir();
  EXPECT_TRUE(writer.close("test").ok());
  return dir;
}

struct StoredFrame {
  std::int64_t pts_ms;
  std::uint32_t crc;
  bool operator==(const StoredFrame&) const = default;
};

// Every segment the index names (by its row id), decoded: each frame's timestamp and CRC.
std::map<std::int64_t, std::vector<StoredFrame>> decode_segments(const fs::path& dir) {
  std::map<std::int64_t, std::vector<StoredFrame>> out;
  sqlite::Database db(dir / "session.db", sqlite::Database::Mode::ReadOnly);
  auto q = db.prepare("SELECT id, path FROM video_files ORDER BY id");
  while (q.step()) {
    auto reader = VideoReader::open(dir / q.column_text(1));
    EXPECT_TRUE(reader) << reader.error().message;
    if (!reader) continue;
    cv::Mat picture;
    std::int64_t pts = 0;
    bool key = false;
    auto& frames = out[q.column_int(0)];
    for (;;) {
      auto more = reader.value()->next_stored(picture, pts, key);
      EXPECT_TRUE(more) << more.error().message;
      if (!more || !more.value()) break;
      frames.push_back({pts, reader.value()->decoded_picture_crc().value()});
    }
  }
  return out;
}

std::map<std::string, std::string> codecs_by_path(const fs::path& dir) {
  std::map<std::string, std::string> out;
  sqlite::Database db(dir / "session.db", sqlite::Database::Mode::ReadOnly);
  auto q = db.prepare("SELECT path, codec FROM video_files");
  while (q.step()) out[q.column_text(0)] = q.column_text(1);
  return out;
}

// The folder's files and their contents (the index as its rows: SQLite may rewrite pages freely).
std::map<std::string, std::string> folder_contents(const fs::path& dir) {
  std::map<std::string, std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!e.is_regular_file() || e.path().filename().string().rfind("session.db", 0) == 0) continue;
    std::ifstream in(e.path(), std::ios::binary);
    out[e.path().filename().string()] = std::string(std::istreambuf_iterator<char>(in), {});
  }
  return out;
}

std::uintmax_t video_bytes(const fs::path& dir) {
  std::uintmax_t n = 0;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".mkv") n += e.file_size();
  return n;
}

}  // namespace

TEST(Compact, RawSegmentsBecomeSmallerBitExactAndASecondRunChangesNothing) {
  const auto root = compact_root("exact");
  const fs::path dir = write_raw_session(root, 3);
  ASSERT_EQ(verify_session(dir).exit_code(), 0);
  const auto before = decode_segments(dir);
  ASSERT_GE(before.size(), 3u);
  const auto bytes_before = video_bytes(dir);

  std::int64_t last_done = 0, total = 0;
  CompactOptions o;
  o.progress = [&](const std::string&, std::int64_t, std::int64_t, std::int64_t done, std::int64_t all) {
    EXPECT_GE(done, last_done);
    last_done = done;
    total = all;
  };
  auto r = compact_session(dir, o);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r.value().segments_compacted, std::int64_t(before.size()));
  EXPECT_EQ(r.value().frames, 45);
  EXPECT_EQ(last_done, 45);
  EXPECT_EQ(total, 45);
  EXPECT_LT(r.value().bytes_after, r.value().bytes_before);
  EXPECT_LT(video_bytes(dir), bytes_before);
  for (const auto& [path, codec] : codecs_by_path(dir)) {
    EXPECT_EQ(codec, "libx264") << path;
    EXPECT_NE(path.find(".x264.mkv"), std::string::npos) << path;
  }
  // The same pictures at the same timestamps; the old files gone, nothing half-made left.
  EXPECT_EQ(decode_segments(dir), before);
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    EXPECT_TRUE(name.find(".mkv") == std::string::npos || name.find(".x264.mkv") != std::string::npos) << name;
    EXPECT_EQ(name.find("compacting"), std::string::npos) << name;
    EXPECT_NE(name, "recording.lock");
  }
  const auto verified = verify_session(dir);
  EXPECT_EQ(verified.exit_code(), 0) << format_report(dir, verified);

  const auto files = folder_contents(dir);
  auto again = compact_session(dir, o);
  ASSERT_TRUE(again) << again.error().message;
  EXPECT_EQ(again.value().segments_compacted, 0);
  EXPECT_EQ(folder_contents(dir), files);

  // FFV1 (intra only) would be larger than these x264 files: they are kept as they are.
  o.codec = "ffv1";
  o.progress = nullptr;
  auto ffv1 = compact_session(dir, o);
  ASSERT_TRUE(ffv1) << ffv1.error().message;
  EXPECT_EQ(ffv1.value().segments_compacted, 0);
  EXPECT_EQ(ffv1.value().segments_kept, std::int64_t(before.size()));
  EXPECT_EQ(folder_contents(dir), files);
  fs::remove_all(root);
}

TEST(Compact, Ffv1OnRequestKeepsThePicturesToo) {
  const auto root = compact_root("ffv1");
  const fs::path dir = write_raw_session(root, 1);
  const auto before = decode_segments(dir);
  CompactOptions o;
  o.codec = "ffv1";
  auto r = compact_session(dir, o);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r.value().segments_compacted, std::int64_t(before.size()));
  for (const auto& [path, codec] : codecs_by_path(dir)) {
    EXPECT_EQ(codec, "ffv1") << path;
    EXPECT_NE(path.find(".ffv1.mkv"), std::string::npos) << path;
  }
  EXPECT_EQ(decode_segments(dir), before);
  EXPECT_EQ(verify_session(dir).exit_code(), 0);
  fs::remove_all(root);
}

// For training: every frame alone in tiles (a shuffled crop decodes the tiles under it), in HuffYUV
// with tables fitted to the segment (static: one decoder for every tile), the pictures the same; a
// second run changes nothing. The live store fits its tables too, from its second segment on (to
// the frame before it): its first segment, in HuffYUV's generic tables, is what compact makes
// smaller; the second is already as small and stays as it is.
TEST(Compact, ForTrainingEveryFrameDecodesAloneInTilesSmallerThanTheLiveStore) {
  const auto root = compact_root("training");
  const fs::path dir = write_raw_session(root, 2, "2x2");
  const auto before = decode_segments(dir);
  ASSERT_EQ(before.size(), 2u);
  const auto bytes_of = [&](const char* name) { return fs::file_size(dir / name); };
  EXPECT_LT(bytes_of("cam0-001.mkv"), bytes_of("cam0-000.mkv") * 95 / 100)
      << "the second segment's tables fitted to the scene: fewer bytes for as many frames";
  const auto bytes_before = video_bytes(dir);
  CompactOptions o;
  o.codec = "ffvhuff";
  auto r = compact_session(dir, o);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r.value().segments_compacted, 1) << fmt::format("{}", fmt::join(r.value().done, "\n"));
  EXPECT_EQ(r.value().segments_kept, 1);
  EXPECT_LT(video_bytes(dir), bytes_before);
  EXPECT_GT(r.value().crops_per_s_before, 0);
  EXPECT_GT(r.value().crops_per_s_after, 0);
  const auto codecs = codecs_by_path(dir);
  EXPECT_TRUE(codecs.count("cam0-000.huff.mkv")) << "the first segment compacted";
  EXPECT_TRUE(codecs.count("cam0-001.mkv")) << "the second kept as it is";
  for (const auto& [path, codec] : codecs) {
    EXPECT_EQ(codec, "ffvhuff") << path;
    auto v = VideoReader::open(dir / path);
    ASSERT_TRUE(v) << v.error().message;
    EXPECT_EQ(v.value()->tiles(), 4) << path << ": the live store's tiles";
    EXPECT_EQ(v.value()->tile_decoders(), 1) << path << ": one set of tables for every tile";
    // Every frame a key frame: a shuffled read decodes the frame asked for and nothing before it.
    std::int64_t pts = 0;
    bool key = false;
    while (v.value()->next_packet(pts, key).value()) EXPECT_TRUE(key) << path << " at " << pts;
  }
  EXPECT_EQ(decode_segments(dir), before);
  EXPECT_EQ(verify_session(dir).exit_code(), 0);
  auto again = compact_session(dir, o);
  ASSERT_TRUE(again) << again.error().message;
  EXPECT_EQ(again.value().segments_compacted, 0);
  fs::remove_all(root);
}

// A kill after each step of a replacement (copy written, copy renamed, index committed): the index
// names complete files that decode to the original pictures, and the next run removes what was left
// and finishes.
TEST(Compact, AnInterruptionAfterEveryStepLeavesAReadableSessionAndTheNextRunFinishes) {
  for (const std::string at : {"written", "renamed", "committed"}) {
    SCOPED_TRACE(at);
    const auto root = compact_root("step-" + at);
    const fs::path dir = write_raw_session(root, 2);
    const auto before = decode_segments(dir);
    CompactOptions o;
    int seen = 0;
    o.after_step = [&](std::string_view step) { return !(step == at && ++seen == 2); };  // the second segment
    auto cut = compact_session(dir, o);
    ASSERT_TRUE(cut) << cut.error().message;
    EXPECT_TRUE(cut.value().stopped);
    EXPECT_EQ(decode_segments(dir), before);
    const auto v = verify_session(dir);
    EXPECT_EQ(v.exit_code(), 0) << format_report(dir, v);
    int leftovers = 0;
    for (const auto& e : fs::directory_iterator(dir)) leftovers += e.path().extension() == ".compacting";
    EXPECT_EQ(leftovers, at == "written" ? 1 : 0);

    auto rest = compact_session(dir, {});
    ASSERT_TRUE(rest) << rest.error().message;
    EXPECT_FALSE(rest.value().stopped);
    const bool leftover_removed =
        std::any_of(rest.value().done.begin(), rest.value().done.end(),
                    [](const std::string& d) { return d.find("interrupted compact") != std::string::npos; });
    EXPECT_TRUE(leftover_removed) << fmt::format("{}", fmt::join(rest.value().done, "\n"));
    for (const auto& [path, codec] : codecs_by_path(dir)) EXPECT_EQ(codec, "libx264") << path;
    EXPECT_EQ(decode_segments(dir), before);
    std::size_t videos = 0;
    for (const auto& e : fs::directory_iterator(dir)) videos += e.path().extension() == ".mkv";
    EXPECT_EQ(videos, before.size()) << "every segment once, in its new file only";
    EXPECT_EQ(verify_session(dir).exit_code(), 0);
    fs::remove_all(root);
  }
}

TEST(Compact, AFrameThatIsNotItsCaptureIsNamedAndItsSegmentLeftAsItWas) {
  const auto root = compact_root("damaged");
  const fs::path dir = write_raw_session(root, 2);
  std::string path;
  {
    sqlite::Database db(dir / "session.db", sqlite::Database::Mode::ReadWrite);
    // As if the stored frame 5 of the second segment were not the bytes the camera sent.
    db.exec(
        "UPDATE frames SET checksum = (checksum | 1) - (checksum & 1) WHERE video_file_id = (SELECT id FROM "
        "video_files ORDER BY id "
        "LIMIT 1 OFFSET 1) AND video_index = 5");
    auto q = db.prepare("SELECT path FROM video_files ORDER BY id LIMIT 1 OFFSET 1");
    ASSERT_TRUE(q.step());
    path = q.column_text(0);
  }
  const auto files_before = fs::file_size(dir / path);
  auto r = compact_session(dir, {});
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find(path), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("frame 5 is not the bytes the camera sent"), std::string::npos) << r.error().message;
  EXPECT_EQ(codecs_by_path(dir).at(path), "ffvhuff");
  EXPECT_EQ(fs::file_size(dir / path), files_before);
  for (const auto& e : fs::directory_iterator(dir)) EXPECT_NE(e.path().extension(), ".compacting");
  fs::remove_all(root);
}

// A store whose names would give two segments one compacted file (not one pvcap names, but a store
// may come from elsewhere) is refused before anything is written.
TEST(Compact, ANewNameThatIsAnotherSegmentsIsRefused) {
  const auto root = compact_root("names");
  const fs::path dir = write_raw_session(root, 2);
  {
    sqlite::Database db(dir / "session.db", sqlite::Database::Mode::ReadWrite);
    auto q = db.prepare("SELECT path FROM video_files ORDER BY id");
    ASSERT_TRUE(q.step());
    const std::string first = q.column_text(0);
    ASSERT_TRUE(q.step());
    const std::string second = q.column_text(0);
    q.reset();
    const std::string taken = first.substr(0, first.find('.')) + ".x264.mkv";
    fs::rename(dir / second, dir / taken);
    db.prepare("UPDATE video_files SET path = ? WHERE path = ?").bind_all(taken, second).run();
  }
  const auto files = folder_contents(dir);
  auto r = compact_session(dir, {});
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("its new name"), std::string::npos) << r.error().message;
  EXPECT_EQ(folder_contents(dir), files);
  fs::remove_all(root);
}

TEST(Compact, ASessionBeingRecordedOrNotClosedIsRefused) {
  const auto root = compact_root("refused");
  const fs::path dir = write_raw_session(root, 1);
  {
    const int fd = ::open((dir / "recording.lock").c_str(), O_CREAT | O_WRONLY | O_CLOEXEC, 0644);
    ASSERT_GE(fd, 0);
    ASSERT_EQ(flock(fd, LOCK_EX | LOCK_NB), 0);  // a live recorder holds it
    auto r = compact_session(dir, {});
    ::close(fd);
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("is being recorded"), std::string::npos) << r.error().message;
  }
  {
    sqlite::Database db(dir / "session.db", sqlite::Database::Mode::ReadWrite);
    db.exec("UPDATE session SET ended_host_ns = NULL");
  }
  auto r = compact_session(dir, {});
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("run pvcap recover first"), std::string::npos) << r.error().message;
  EXPECT_EQ(codecs_by_path(dir).begin()->second, "ffvhuff");
  fs::remove_all(root);
}
