// The session store end to end without devices: written by SessionWriter (segments, FFV1 so
// pixels compare exactly), read back by SessionReader, checked by verify, damaged and recovered,
// and older schemas upgraded.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include <fmt/format.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>
#include <opencv2/imgproc.hpp>

#include "codec/sensel_frame.h"
#include "core/rig_config.h"
#include "core/time.h"
#include "sim/scene.h"
#include "storage/index/database.h"
#include "storage/index/pressure_blob.h"
#include "storage/index/session_reader.h"
#include "storage/index/video_repair.h"
#include "storage/tools/verify.h"
#include "storage/video/frame_checksum.h"
#include "storage/video/video_reader.h"
#include "storage/video/view_video.h"
#include "storage/writer/frame_spill.h"
#include "storage/writer/recover.h"
#include "storage/writer/session_writer.h"

namespace fs = std::filesystem;
using namespace pvcap;

namespace {

std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream out;
  out << in.rdbuf();
  return out.str();
}

// What pvcap logs at warning level or above while one of these is alive.
class LoggedProblems {
 public:
  LoggedProblems() {
    sink_->set_level(spdlog::level::warn);
    spdlog::default_logger()->sinks().push_back(sink_);
  }
  ~LoggedProblems() {
    auto& sinks = spdlog::default_logger()->sinks();
    sinks.erase(std::remove(sinks.begin(), sinks.end(), sink_), sinks.end());
  }
  std::string text() const { return out_.str(); }

 private:
  std::ostringstream out_;
  std::shared_ptr<spdlog::sinks::ostream_sink_mt> sink_ = std::make_shared<spdlog::sinks::ostream_sink_mt>(out_);
};

fs::path temp_root(const std::string& name) {
  const auto d = fs::temp_directory_path() / ("pvcap-test-store-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(d);
  return d;
}

cv::Mat noise_frame(int camera, int i) {
  cv::Mat m(48, 64, CV_8UC3);
  cv::RNG rng(std::uint64_t(camera * 100000 + i + 1));
  rng.fill(m, cv::RNG::UNIFORM, 0, 256);
  return m;
}

std::vector<std::uint16_t> pressure_counts(int i) {
  std::vector<std::uint16_t> c(std::size_t(sensel::kMediumDetail.cells()), 0);
  for (int k = 0; k < 40; ++k) c[std::size_t((i * 7 + k * 13) % c.size())] = std::uint16_t(10 + i + k);
  return c;
}

std::vector<std::uint8_t> pressure_payload(int i, const std::vector<std::uint16_t>& counts) {
  sensel::Frame f;
  f.content = sensel::kPressure;
  f.counter = std::uint8_t(i);
  f.timestamp_us = std::uint32_t(i * 8000);
  f.pressure = sensel::PressureImage{3, counts};
  return sensel::encode_frame(f);
}

// A store of `seconds` at 15 Hz: two cameras (segments of 1 s), pressure at 125 Hz, one sample per
// camera frame pair, protocol events around two actions, notes, a calibration.
struct WrittenStore {
  fs::path dir;
  std::int64_t t0 = 0;
  std::vector<std::int64_t> cams;
  int samples = 0;
};

// `raw_first`: the first camera is a Bayer camera stored raw (its frames the mosaic of the noise).
// `view_videos`: the store's setting (storage/video/view_video.h).
// `raw_tiles`: the store's setting (storage/video/bayer_tiles.h; auto leaves a 64x48 camera untiled).
WrittenStore write_store(const fs::path& root, double seconds, bool raw_first = false, bool view_videos = true,
                         const std::string& raw_tiles = "auto") {
  WrittenStore out;
  const auto rig = parse_rig_config(
      fmt::format("name: store-test\ncameras:\n  - {{name: camA, address: 10.0.0.1}}\n  - {{name: camB, address: "
                  "10.0.0.2}}\nstore: {{video_codec: ffv1, video_pixel_format: bgr0, segment_seconds: 1, min_free_mb: "
                  "0, reserve_mb: 1, view_videos: {}, raw_tiles: {}}}\n",
                  view_videos, raw_tiles),
      "store-test.yaml");
  out.t0 = host_now().ns;
  WriterOptions options;
  options.view_backlog_frames = SIZE_MAX;  // every frame in its view video, however loaded the machine
  auto w = SessionWriter::create(root, rig, wall_now_ns(), out.t0, options);
  EXPECT_TRUE(w) << w.error().message;
  auto& writer = *w.value();
  for (const char* name : {"camA", "camB"}) {
    const std::string format = raw_first && out.cams.empty() ? "BayerRG8" : "";
    auto id = writer.add_camera(DeviceRecord{"camera", name, "v", "m", std::string("S-") + name, "a", "f", "{}"}, 64,
                                48, format);
    EXPECT_TRUE(id) << id.error().message;
    out.cams.push_back(id.value());
  }
  const std::int64_t sensel =
      writer.add_device(DeviceRecord{"sensel", "sensel", "Sensel", "Morph", "SM1", "tty", "1", "{}"}).value();
  EXPECT_TRUE(writer.set_participant({"P017", "medium", "left_first"}).ok());
  EXPECT_TRUE(writer.set_conditions({"L-R", "white_vinyl"}).ok());
  EXPECT_TRUE(writer.add_calibration({out.cams[0], 123, "fiducials", "[[1,0,0],[0,1,0],[0,0,1]]", 0.4, 0.3, "{}"}));
  writer.start();

  const std::int64_t frame_ns = 66'666'667, pressure_ns = 8'000'000;
  const int frames = int(seconds * 15);
  for (int p = 0; p * pressure_ns < std::int64_t(seconds * 1e9) + 100'000'000; ++p) {
    const auto counts = pressure_counts(p);
    PressureRecord r{sensel,
                     0,
                     std::uint64_t(p),
                     0,
                     p * pressure_ns,
                     out.t0 + p * pressure_ns,
                     1000,
                     47,
                     27,
                     4,
                     4,
                     pressure_payload(p, counts),
                     out.t0 + p * pressure_ns};
    r.base = 3;
    r.counts = counts;
    writer.record(std::move(r));
  }
  for (int i = 0; i < frames; ++i) {
    const std::int64_t t = out.t0 + 10'000'000 + i * frame_ns;
    SampleRecord s{std::uint64_t(i), i, t, t, 0, {}, {}, {}, {}};
    for (std::size_t c = 0; c < out.cams.size(); ++c) {
      FrameRecord f{out.cams[c], 0, std::uint64_t(i), std::uint64_t(i), i * 1000, t, 0, "good", false, "", {}, {}, t};
      cv::Mat image = noise_frame(int(c), i);
      if (writer.stores_raw(out.cams[c])) {
        image = sim::to_sensor_format(image, "BayerRG8");
        f.checksum = stored_mosaic_crc(image, writer.raw_plane_order(out.cams[c]));
      }
      EXPECT_TRUE(writer.submit_video(out.cams[c], image, f));
      s.cameras.push_back({out.cams[c], 0, std::uint64_t(i), 0});
    }
    // Pressure frames at k * 8 ms; the sample at 10 ms + i * 66.67 ms lies between two of them.
    const std::int64_t rel = t - out.t0;
    const std::uint64_t before = std::uint64_t(rel / pressure_ns);
    s.pressure_before = SampleFrameRef{sensel, 0, before, std::int64_t(before) * pressure_ns - rel};
    s.pressure_after = SampleFrameRef{sensel, 0, before + 1, std::int64_t(before + 1) * pressure_ns - rel};
    s.pressure =
        std::llabs(s.pressure_before->offset_ns) <= s.pressure_after->offset_ns ? s.pressure_before : s.pressure_after;
    writer.record(std::move(s));
    ++out.samples;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));  // keep the encoder queues short
  }
  writer.record(ProtocolEventRecord{out.t0 + 200'000'000, "action_start", 1, "press_index", "right", "high", 3, ""});
  writer.record(ProtocolEventRecord{out.t0 + 900'000'000, "action_end", 1, "press_index", "right", "high", 3, ""});
  writer.record(ProtocolEventRecord{out.t0 + 1'000'000'000, "action_start", 2, "flat_palm", "right", "low", 3, ""});
  writer.record(OperatorNoteRecord{out.t0 + 500'000'000, "participant sneezed"});
  out.dir = writer.dir();
  EXPECT_TRUE(writer.close("test").ok());
  return out;
}

}  // namespace

TEST(PressureBlob, RoundTripsAndRejectsDamage) {
  const auto counts = pressure_counts(5);
  const auto blob = compress_counts(counts);
  EXPECT_LT(blob.size(), counts.size() * 2 / 4) << "mostly-zero images compress";
  auto back = decompress_counts(blob, counts.size());
  ASSERT_TRUE(back) << back.error().message;
  EXPECT_EQ(back.value(), counts);
  EXPECT_FALSE(decompress_counts(blob, counts.size() + 1)) << "a grid of another size is refused";
  EXPECT_FALSE(
      decompress_counts(std::vector<std::uint8_t>(blob.begin(), blob.begin() + long(blob.size() / 2)), counts.size()));
  std::vector<std::uint8_t> junk = {1, 2, 3, 4, 5};
  EXPECT_FALSE(decompress_counts(junk, counts.size()));
}

TEST(SessionStore, WrittenInSegmentsAndReadBackExactly) {
  const auto root = temp_root("rw");
  const auto st = write_store(root, 2.5);

  // Segments of one second, each finished with its frame count.
  sqlite::Database db(st.dir / "session.db", sqlite::Database::Mode::ReadOnly);
  auto v = db.prepare("SELECT count(*), sum(state = 'closed'), sum(frames) FROM video_files");
  ASSERT_TRUE(v.step());
  EXPECT_GE(v.column_int(0), 6) << "2.5 s in 1 s segments: 3 per camera";
  EXPECT_EQ(v.column_int(1), v.column_int(0));
  EXPECT_EQ(v.column_int(2), 2 * st.samples);

  auto r = SessionReader::open(st.dir);
  ASSERT_TRUE(r) << r.error().message;
  auto& reader = *r.value();
  EXPECT_EQ(reader.info().participant->pseudonym, "P017");
  EXPECT_EQ(reader.info().participant->hand_order, "left_first");
  EXPECT_EQ(reader.info().conditions->sensor_overlay, "white_vinyl");
  ASSERT_EQ(reader.cameras().size(), 2u);
  EXPECT_EQ(reader.cameras()[1].name, "camB");
  ASSERT_EQ(reader.sample_count(), std::size_t(st.samples));

  // Every sample: both cameras' pixels exactly as written, the pressure nearest and interpolated.
  for (std::size_t i = 0; i < reader.sample_count(); ++i) {
    auto s = reader.sample(i, PressureMode::Interpolated);
    ASSERT_TRUE(s) << s.error().message;
    for (int c = 0; c < 2; ++c) {
      ASSERT_FALSE(s.value().images[std::size_t(c)].empty()) << "sample " << i << " camera " << c;
      EXPECT_EQ(cv::norm(s.value().images[std::size_t(c)], noise_frame(c, int(i)), cv::NORM_INF), 0)
          << "sample " << i << " camera " << c;
    }
    ASSERT_TRUE(s.value().pressure);
    EXPECT_EQ(s.value().pressure->counts, pressure_counts(int(s.value().info.pressure->sequence)));
    const auto& b = *s.value().info.before;
    const auto& a = *s.value().info.after;
    const double w = double(-b.offset_ns) / double(a.offset_ns - b.offset_ns);
    const auto cb = pressure_counts(int(b.sequence)), ca = pressure_counts(int(a.sequence));
    for (std::size_t k = 0; k < cb.size(); k += 97)
      EXPECT_NEAR(s.value().pressure_image.at<float>(int(k)), (1 - w) * cb[k] + w * ca[k], 1e-3);
  }
  EXPECT_LE(reader.open_videos(), 4u) << "three segments per camera read: each camera's last two stay open";
  // Random access backwards after sequential reading still lands on the right frame (its segment
  // opened again).
  for (std::size_t i : {std::size_t(30), std::size_t(3), std::size_t(17), std::size_t(0)}) {
    auto s = reader.sample(i);
    ASSERT_TRUE(s);
    EXPECT_EQ(cv::norm(s.value().images[0], noise_frame(0, int(i)), cv::NORM_INF), 0) << i;
  }

  // By time and by action.
  const std::int64_t t20 = st.t0 + 10'000'000 + 20 * 66'666'667;
  EXPECT_EQ(reader.sample_at(t20 + 20'000'000).value(), 20u);
  EXPECT_EQ(reader.sample_at(st.t0 - 5'000'000'000).value(), 0u);
  auto actions = reader.actions();
  ASSERT_TRUE(actions);
  ASSERT_EQ(actions.value().size(), 2u);
  EXPECT_EQ(actions.value()[0].action, "press_index");
  EXPECT_EQ(actions.value()[0].first_sample, 3u);  // first sample at or after 200 ms: 10 + 3 * 66.7 ms
  EXPECT_EQ(actions.value()[0].end_sample, 14u);   // first at or after 900 ms
  EXPECT_EQ(actions.value()[1].action, "flat_palm");
  EXPECT_EQ(actions.value()[1].end_sample, reader.sample_count()) << "an open action runs to the session's end";
  EXPECT_EQ(reader.operator_notes().value().at(0).text, "participant sneezed");
  EXPECT_EQ(reader.calibrations().value().at(0).method, "fiducials");
  auto stats = reader.stream_statistics();
  ASSERT_TRUE(stats);
  EXPECT_EQ(stats.value()[0].frames, std::uint64_t(st.samples));
  EXPECT_EQ(stats.value()[0].in_video, std::uint64_t(st.samples));
  EXPECT_NEAR(stats.value()[2].mean_rate_hz, 125.0, 0.5);

  const auto report = verify_session(st.dir);
  EXPECT_EQ(report.exit_code(), 0) << format_report(st.dir, report);
  // The videos are checked side by side, and said in the index's order, each with all its frames.
  std::vector<std::string> said;
  for (const auto& f : report.facts)
    if (f.find(" frames in the video, ") != std::string::npos) said.push_back(f.substr(0, f.find(':')));
  sqlite::Database index(st.dir / "session.db", sqlite::Database::Mode::ReadOnly);
  auto q = index.prepare(
      "SELECT path, (SELECT count(*) FROM frames f WHERE f.video_file_id = v.id AND f.kept = 1) FROM "
      "video_files v ORDER BY id");
  std::vector<std::string> indexed;
  while (q.step()) {
    indexed.push_back(q.column_text(0));
    const std::string want =
        fmt::format("{}: {} frames in the video, {} kept", indexed.back(), q.column_int(1), q.column_int(1));
    EXPECT_TRUE(std::any_of(report.facts.begin(), report.facts.end(),
                            [&](const std::string& f) { return f.rfind(want, 0) == 0; }))
        << want << "\n"
        << format_report(st.dir, report);
  }
  EXPECT_GE(indexed.size(), 4u);
  EXPECT_EQ(said, indexed);
  EXPECT_FALSE(reader.sample(reader.sample_count()));
  fs::remove_all(root);
}

TEST(SessionStore, RecoverClosesACutSegmentAndMarksWhatWasLost) {
  const auto root = temp_root("recover");
  const auto st = write_store(root, 2.5);
  // As a kill leaves it: the last segment of camB still open and cut, the session without an end.
  std::string last;
  {
    sqlite::Database db(st.dir / "session.db", sqlite::Database::Mode::ReadWrite);
    auto q = db.prepare("SELECT id, path FROM video_files WHERE device_id = ? ORDER BY segment DESC LIMIT 1");
    q.bind_all(st.cams[1]);
    ASSERT_TRUE(q.step());
    last = q.column_text(1);
    db.prepare("UPDATE video_files SET state = 'open', frames = NULL WHERE id = ?").bind_all(q.column_int(0)).run();
    db.exec("UPDATE session SET ended_host_ns = NULL, end_reason = NULL");
  }
  fs::resize_file(st.dir / last, fs::file_size(st.dir / last) * 6 / 10);
  const fs::path view = st.dir / view_video_path(last);  // its view video, cut with it
  ASSERT_TRUE(fs::exists(view));
  fs::resize_file(view, fs::file_size(view) * 6 / 10);
  {
    // A cut file is what verify and recover expect: their reports say it, FFmpeg's complaints
    // about it ("File ended prematurely") are not errors on the operator's console.
    const LoggedProblems logged;
    const auto before = verify_session(st.dir);
    EXPECT_EQ(before.exit_code(), 3) << format_report(st.dir, before);
    auto rec = recover_session(st.dir);
    ASSERT_TRUE(rec) << rec.error().message;
    EXPECT_TRUE(rec.value().was_interrupted);
    EXPECT_EQ(logged.text(), "");
  }
  EXPECT_TRUE(fs::exists(st.dir / (last.substr(0, last.size() - 4) + ".interrupted.mkv"))) << "the original is kept";
  {
    // The view video finished too: its readable frames, and a frame past its first found by seeking
    // (a cut file cannot seek).
    auto frames = count_video_frames(view);
    ASSERT_TRUE(frames) << frames.error().message;
    ASSERT_GE(frames.value(), 2);
    auto first = VideoReader::open(view);
    ASSERT_TRUE(first) << first.error().message;
    cv::Mat image;
    std::int64_t ms = 0;
    ASSERT_TRUE(first.value()->next(image, ms).value());
    ASSERT_TRUE(first.value()->next(image, ms).value());
    auto again = VideoReader::open(view);
    ASSERT_TRUE(again);
    auto found = again.value()->read_at(ms, image);
    ASSERT_TRUE(found) << found.error().message;
    EXPECT_TRUE(found.value());
  }
  const auto after = verify_session(st.dir);
  EXPECT_EQ(after.exit_code(), 3) << format_report(st.dir, after);
  for (const auto& e : after.errors) ADD_FAILURE() << e;

  // Every sample is readable: camB's lost frames show as missing images with their reason.
  auto r = SessionReader::open(st.dir);
  ASSERT_TRUE(r) << r.error().message;
  int lost = 0;
  for (std::size_t i = 0; i < r.value()->sample_count(); ++i) {
    auto s = r.value()->sample(i);
    ASSERT_TRUE(s) << s.error().message;
    EXPECT_EQ(cv::norm(s.value().images[0], noise_frame(0, int(i)), cv::NORM_INF), 0);
    if (s.value().images[1].empty()) {
      ++lost;
      EXPECT_EQ(s.value().info.cameras[1].reason, "lost_at_interruption");
    } else {
      EXPECT_EQ(cv::norm(s.value().images[1], noise_frame(1, int(i)), cv::NORM_INF), 0);
      EXPECT_EQ(lost, 0) << "frames are lost from the end only";
    }
  }
  EXPECT_GT(lost, 0);
  EXPECT_LT(lost, 8) << "a cut of 40 % of a 15-frame segment";
  EXPECT_NE(r.value()->info().end_reason.find("interrupted"), std::string::npos);

  // A recover killed between its two renames (the finished copy still under its temporary name):
  // the next one completes it.
  fs::rename(st.dir / last, st.dir / (last + ".recovering"));
  {
    sqlite::Database db(st.dir / "session.db", sqlite::Database::Mode::ReadWrite);
    db.prepare("UPDATE video_files SET state = 'open' WHERE path = ?").bind_all(last).run();
  }
  auto finish = recover_session(st.dir);
  ASSERT_TRUE(finish) << finish.error().message;
  ASSERT_EQ(finish.value().done.size(), 1u);
  EXPECT_NE(finish.value().done[0].find("finishing an earlier recover"), std::string::npos) << finish.value().done[0];
  EXPECT_EQ(verify_session(st.dir).exit_code(), 3);

  // A recover killed after both renames, before the index said so (the closed copy under the segment's
  // name, the original aside): the next one completes it and leaves both files as they are. (CI's
  // StoreCrash test once killed a recover there: "cam1-000.interrupted.mkv: already exists".)
  {
    sqlite::Database db(st.dir / "session.db", sqlite::Database::Mode::ReadWrite);
    db.prepare("UPDATE video_files SET state = 'open' WHERE path = ?").bind_all(last).run();
  }
  const std::string closed_copy = read_file(st.dir / last);
  auto finish_after = recover_session(st.dir);
  ASSERT_TRUE(finish_after) << finish_after.error().message;
  ASSERT_EQ(finish_after.value().done.size(), 1u);
  EXPECT_NE(finish_after.value().done[0].find("finishing an earlier recover"), std::string::npos)
      << finish_after.value().done[0];
  EXPECT_EQ(read_file(st.dir / last), closed_copy) << "the closed copy is not closed again";
  EXPECT_EQ(verify_session(st.dir).exit_code(), 3);

  // A second run finds nothing to do.
  auto again = recover_session(st.dir);
  ASSERT_TRUE(again);
  EXPECT_TRUE(again.value().done.empty());
  fs::remove_all(root);
}

TEST(SessionStore, ReaderRefusesForeignAndDamagedStoresWithAMessage) {
  const auto root = temp_root("foreign");
  fs::create_directories(root / "s");
  EXPECT_NE(SessionReader::open(root / "s").error().message.find("no session.db"), std::string::npos);
  std::ofstream(root / "s" / "session.db") << "a shopping list, not a database";
  auto foreign = SessionReader::open(root / "s");
  ASSERT_FALSE(foreign);
  EXPECT_NE(foreign.error().message.find("session.db"), std::string::npos) << foreign.error().message;

  // A real store whose videos are gone and whose pressure blobs are damaged: errors per sample, no crash.
  const auto st = write_store(root / "real", 1.0);
  for (const auto& e : fs::directory_iterator(st.dir))
    if (e.path().extension() == ".mkv") fs::remove(e.path());
  {
    sqlite::Database db(st.dir / "session.db", sqlite::Database::Mode::ReadWrite);
    db.exec("UPDATE pressure_frames SET counts = x'00112233'");
  }
  auto r = SessionReader::open(st.dir);
  ASSERT_TRUE(r) << r.error().message;
  auto s = r.value()->sample(0);
  ASSERT_FALSE(s);
  EXPECT_NE(s.error().message.find(".mkv"), std::string::npos) << s.error().message;
  auto p = r.value()->pressure_frame(0);
  ASSERT_FALSE(p);
  EXPECT_NE(p.error().message.find("zlib"), std::string::npos) << p.error().message;
  fs::remove_all(root);
}

TEST(SessionStore, OlderSchemasAreMigratedAfterABackup) {
  const auto root = temp_root("migrate");
  fs::create_directories(root);
  const auto path = root / "session.db";
  {
    // A store as pvcap 0.1 wrote it (schema 1), with one Sensel frame.
    sqlite::Database db(path, sqlite::Database::Mode::Create);
    create_schema(db, 1);
    db.exec("INSERT INTO session VALUES (1, 0, 0, 1, 'done', '0.1', 'r', 'r.yaml', 'name: r', 0)");
    db.exec("INSERT INTO devices VALUES (1, 'sensel', 'sensel', '', '', '', '', '', '{}')");
    db.prepare("INSERT INTO pressure_frames VALUES (1, 0, 7, 0, 0, 0, 0, 47, 27, 4, 4, ?)")
        .bind_all(pressure_payload(7, pressure_counts(7)))
        .run();
  }
  std::vector<int> passed;
  std::vector<std::string> said;
  {
    auto index = SessionIndex::open_for_update(path, &passed, [&](const std::string& s) { said.push_back(s); });
  }
  EXPECT_EQ(passed, (std::vector<int>{2, 3, 4, 5, 6, 7}));
  // The operator sees each step, and how far the long one (every pressure frame decoded) has come.
  EXPECT_EQ(said, (std::vector<std::string>{
                      "upgrading the index from version 1 to 2", "upgrading the index from version 2 to 3",
                      "raw pressure counts: 1 of 1 frames", "upgrading the index from version 3 to 4",
                      "upgrading the index from version 4 to 5", "upgrading the index from version 5 to 6",
                      "upgrading the index from version 6 to 7"}));
  EXPECT_TRUE(fs::exists(root / "session.db.v1.bak"));
  {
    sqlite::Database backup(root / "session.db.v1.bak", sqlite::Database::Mode::ReadOnly);
    EXPECT_EQ(backup.user_version(), 1) << "the backup is the store as it was";
  }
  auto r = SessionReader::open(root);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r.value()->info().schema_version, kSchemaVersion);
  auto p = r.value()->pressure_frame(7);
  ASSERT_TRUE(p) << p.error().message;
  EXPECT_EQ(p.value().counts, pressure_counts(7)) << "counts filled from the device payload";

  // A store from a newer pvcap is refused, not guessed at.
  {
    sqlite::Database db(path, sqlite::Database::Mode::ReadWrite);
    db.set_user_version(kSchemaVersion + 1);
  }
  EXPECT_THROW(SessionIndex::open_for_update(path), sqlite::SqliteError);
  EXPECT_FALSE(SessionReader::open(root));
  fs::remove_all(root);
}

// A version-3 store (before raw video: the same tables without the videos' layout columns, every
// video in colour) is read as it is, without an upgrade: its images and pressure come back.
TEST(SessionStore, AVersion3StoreIsReadWithoutAnUpgrade) {
  const auto root = temp_root("v3");
  const auto st = write_store(root, 1.0);
  std::string expected_first;
  {
    auto r = SessionReader::open(st.dir);
    ASSERT_TRUE(r);
    auto s = r.value()->sample(3);
    ASSERT_TRUE(s);
    expected_first = fmt::format("{}", cv::sum(s.value().images[0])[0]);
  }
  {
    sqlite::Database db(st.dir / "session.db", sqlite::Database::Mode::ReadWrite);
    for (const char* column : {"layout", "bayer_format", "bit_depth"})
      db.exec(fmt::format("ALTER TABLE video_files DROP COLUMN {}", column));
    db.set_user_version(3);
  }
  auto r = SessionReader::open(st.dir);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r.value()->info().schema_version, 3);
  auto s = r.value()->sample(3);
  ASSERT_TRUE(s) << s.error().message;
  EXPECT_EQ(fmt::format("{}", cv::sum(s.value().images[0])[0]), expected_first);
  EXPECT_TRUE(s.value().pressure);
  auto raw = r.value()->raw_image(3, 0);
  ASSERT_FALSE(raw) << "a colour video has no mosaic";
  fs::remove_all(root);
}

// A viewer's half-size reads of a raw camera skip the second green (storage/video/video_reader.h): the
// image is the mosaic's R, first green and B. A mosaic read, or a checked read, of the same frame
// then opens the video whole and gets every bit.
TEST(SessionStore, HalfSizeViewsSkipTheSecondGreenAndMosaicReadsStillGetEveryBit) {
  const auto root = temp_root("three-planes");
  const auto st = write_store(root, 1.5, /*raw_first=*/true);
  auto r = SessionReader::open(st.dir);
  ASSERT_TRUE(r) << r.error().message;
  r.value()->set_demosaic(Demosaic::HalfSize);
  for (const std::size_t i : {3u, 12u, 4u}) {
    auto view = r.value()->image(i, 0);
    ASSERT_TRUE(view) << view.error().message;
    auto mosaic = r.value()->raw_image(i, 0);
    ASSERT_TRUE(mosaic) << mosaic.error().message;
    const cv::Mat& m = mosaic.value();
    ASSERT_EQ(view.value().size(), cv::Size(m.cols / 2, m.rows / 2));
    // BayerRG: R G / G B; the first row's green is the one kept.
    std::vector<cv::Mat> bgr(3);
    cv::extractChannel(cv::Mat(m.rows / 2, m.cols / 2, CV_8UC2, m.data + m.step[0], m.step[0] * 2), bgr[0], 1);
    cv::extractChannel(cv::Mat(m.rows / 2, m.cols / 2, CV_8UC2, m.data, m.step[0] * 2), bgr[1], 1);
    cv::extractChannel(cv::Mat(m.rows / 2, m.cols / 2, CV_8UC2, m.data, m.step[0] * 2), bgr[2], 0);
    cv::Mat expected;
    cv::merge(bgr, expected);
    EXPECT_EQ(cv::norm(view.value(), expected, cv::NORM_INF), 0.0) << "sample " << i;
    // Checked reads decode the whole picture: its checksum holds.
    r.value()->set_check_checksums(true);
    auto checked = r.value()->image(i, 0);
    ASSERT_TRUE(checked) << checked.error().message;
    EXPECT_GT(cv::norm(checked.value(), expected, cv::NORM_INF), 0.0) << "the mean of both greens, not one";
    r.value()->set_check_checksums(false);
    // At a viewer's size: the same image, scaled (bilinear). A colour camera's too.
    r.value()->set_image_size({20, 15});
    auto small = r.value()->image(i, 0);
    ASSERT_TRUE(small) << small.error().message;
    cv::Mat want;
    cv::resize(expected, want, {20, 15}, 0, 0, cv::INTER_LINEAR);
    EXPECT_EQ(cv::norm(small.value(), want, cv::NORM_INF), 0.0) << "sample " << i;
    auto colour = r.value()->image(i, 1);
    ASSERT_TRUE(colour) << colour.error().message;
    EXPECT_EQ(colour.value().size(), cv::Size(20, 15));
    r.value()->set_image_size({});
  }
  EXPECT_LE(r.value()->open_videos(), 4u);
  fs::remove_all(root);
}

// A region of a raw camera's image, demosaiced alone, is the same pixels as the whole image cut
// there: at odd and even corners, at the image's edges, and the whole image itself; a colour
// camera's region is its image cut.
TEST(SessionStore, ARegionDemosaicedAloneIsTheWholeImagesPixels) {
  for (const std::string tiles : {"auto", "4x3"}) {  // one picture per frame; 16x16 tiles
  SCOPED_TRACE(tiles);
  const auto root = temp_root("region");
  const auto st = write_store(root, 1.5, /*raw_first=*/true, true, tiles);
  {
    sqlite::Database db(st.dir / "session.db", sqlite::Database::Mode::ReadOnly);
    auto q = db.prepare("SELECT path FROM video_files WHERE device_id = ? ORDER BY segment LIMIT 1");
    q.bind_all(st.cams[0]);
    ASSERT_TRUE(q.step());
    auto video = VideoReader::open(st.dir / q.column_text(0));
    ASSERT_TRUE(video) << video.error().message;
    EXPECT_EQ(video.value()->tiles(), tiles == "4x3" ? 12 : 1);
  }
  auto r = SessionReader::open(st.dir);
  ASSERT_TRUE(r) << r.error().message;
  for (const std::size_t camera : {0u, 1u})
    for (const std::size_t i : {3u, 12u}) {
      auto whole = r.value()->image(i, camera);
      ASSERT_TRUE(whole) << whole.error().message;
      const cv::Mat& w = whole.value();
      ASSERT_FALSE(w.empty());
      for (const cv::Rect box : {cv::Rect(5, 3, 17, 11), cv::Rect(4, 2, 16, 10), cv::Rect(0, 0, 9, 7),
                                 cv::Rect(w.cols - 13, w.rows - 9, 13, 9), cv::Rect({0, 0}, w.size())}) {
        auto region = r.value()->image_region(i, camera, box);
        ASSERT_TRUE(region) << region.error().message;
        EXPECT_EQ(cv::norm(region.value(), w(box), cv::NORM_INF), 0.0)
            << "camera " << camera << ", sample " << i << ", box " << box;
      }
    }
  // With checksums checked, the region's frame is read whole and holds to its checksum.
  r.value()->set_check_checksums(true);
  auto checked = r.value()->image_region(12, 0, {5, 3, 17, 11});
  ASSERT_TRUE(checked) << checked.error().message;
  r.value()->set_check_checksums(false);
  auto outside = r.value()->image_region(3, 0, {10, 10, 10000, 10});
  ASSERT_FALSE(outside);
  EXPECT_NE(outside.error().message.find("is not inside"), std::string::npos) << outside.error().message;
  fs::remove_all(root);
  }
}

// The view videos beside the lossless ones (storage/video/view_video.h): one per segment, read by a viewer
// in their place (the same frame, lossy, a third of the size), and never by a read that wants the
// record; a view video that is missing or cut short is read past, from the lossless video.
TEST(SessionStore, ViewVideosStandInForTheLosslessOnesAndNeverForTheRecord) {
  const auto root = temp_root("views");
  const auto st = write_store(root, 2.5, /*raw_first=*/true);
  std::vector<std::string> segments, of_camera_a;
  {
    sqlite::Database db(st.dir / "session.db", sqlite::Database::Mode::ReadOnly);
    auto q = db.prepare("SELECT path, device_id FROM video_files ORDER BY segment, device_id");
    while (q.step()) {
      segments.push_back(q.column_text(0));
      if (q.column_int(1) == st.cams[0]) of_camera_a.push_back(q.column_text(0));
    }
  }
  ASSERT_GE(of_camera_a.size(), 3u) << "2.5 s in 1 s segments";
  for (const auto& seg : segments) EXPECT_TRUE(fs::exists(st.dir / "views" / seg)) << seg;
  std::int64_t kept = 0;
  {
    sqlite::Database db(st.dir / "session.db", sqlite::Database::Mode::ReadOnly);
    auto q = db.prepare("SELECT count(*) FROM frames WHERE kept = 1 AND video_file_id IS NOT NULL");
    ASSERT_TRUE(q.step());
    kept = q.column_int(0);
  }
  // What verify says of them: a fact (they are not the record), with the kept frames they hold.
  auto view_fact = [&] {
    const VerifyReport report = verify_session(st.dir);
    EXPECT_EQ(report.exit_code(), 0) << format_report(st.dir, report);
    std::string found;
    for (const auto& f : report.facts)
      if (f.rfind("view videos", 0) == 0 || f.rfind("views/", 0) == 0) found += f + "\n";
    return found;
  };
  EXPECT_EQ(view_fact(), fmt::format("view videos (the replay's small copies, not the record): {} of {} segments, "
                                     "{} of {} kept frames\n",
                                     segments.size(), segments.size(), kept, kept));
  EXPECT_EQ(view_video_path("cam0-002.x264.mkv"), fs::path("views/cam0-002.mkv")) << "a compacted segment's";

  // The lossless images at the viewer's size, and the same read through the view videos.
  const cv::Size size = view_video_size(64, 48);
  ASSERT_EQ(size, cv::Size(32, 24)) << "the half size: smaller than a replay's view";
  EXPECT_EQ(view_video_size(1920, 1080), cv::Size(640, 360));
  EXPECT_EQ(view_video_size(2448, 2048), cv::Size(430, 360));
  auto lossless = SessionReader::open(st.dir);
  auto viewed = SessionReader::open(st.dir);
  ASSERT_TRUE(lossless && viewed);
  for (auto* r : {lossless.value().get(), viewed.value().get()}) {
    r->set_demosaic(Demosaic::HalfSize);
    r->set_image_size(size);
  }
  viewed.value()->set_view_videos(true);
  auto image = [](SessionReader& r, std::size_t i, std::size_t c) {
    auto m = r.image(i, c);
    EXPECT_TRUE(m) << m.error().message;
    return m ? m.value() : cv::Mat();
  };
  const std::size_t n = std::size_t(st.samples);
  for (std::size_t c = 0; c < 2; ++c)
    for (std::size_t i = 1; i + 1 < n; ++i) {
      const cv::Mat v = image(*viewed.value(), i, c);
      ASSERT_EQ(v.size(), size);
      const cv::Mat own = image(*lossless.value(), i, c);
      // Lossy, and its own frame: nearer the lossless image of its sample than its neighbours'.
      const double err = cv::norm(v, own, cv::NORM_L1);
      EXPECT_GT(err, 0.0) << "camera " << c << " sample " << i << ": read from the lossless video";
      EXPECT_LT(err, cv::norm(v, image(*lossless.value(), i - 1, c), cv::NORM_L1)) << "camera " << c << " sample " << i;
      EXPECT_LT(err, cv::norm(v, image(*lossless.value(), i + 1, c), cv::NORM_L1)) << "camera " << c << " sample " << i;
    }
  EXPECT_EQ(viewed.value()->open_videos(), 0u) << "no lossless video opened: every frame came from a view";

  // The record is never read from a view: mosaics, and reads that check the capture checksums.
  for (const std::size_t i : {2u, 20u}) {
    auto mosaic = viewed.value()->raw_image(i, 0);
    auto want = lossless.value()->raw_image(i, 0);
    ASSERT_TRUE(mosaic && want);
    EXPECT_EQ(cv::norm(mosaic.value(), want.value(), cv::NORM_INF), 0.0);
    viewed.value()->set_check_checksums(true);
    lossless.value()->set_check_checksums(true);
    EXPECT_EQ(cv::norm(image(*viewed.value(), i, 0), image(*lossless.value(), i, 0), cv::NORM_INF), 0.0);
    viewed.value()->set_check_checksums(false);
    lossless.value()->set_check_checksums(false);
  }

  // Camera A's first view video gone, its second cut to a third (what it still holds before the cut
  // may be read, then it is read past): every read still answers, what the views lack comes from the
  // lossless video, exactly, and the third segment's frames from its view.
  fs::remove(st.dir / view_video_path(of_camera_a[0]));
  const fs::path cut = st.dir / view_video_path(of_camera_a[1]);
  ASSERT_TRUE(fs::exists(cut)) << cut;
  fs::resize_file(cut, fs::file_size(cut) / 3);
  auto after = SessionReader::open(st.dir);
  ASSERT_TRUE(after);
  after.value()->set_demosaic(Demosaic::HalfSize);
  after.value()->set_image_size(size);
  after.value()->set_view_videos(true);
  std::size_t exact = 0, from_views = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const cv::Mat v = image(*after.value(), i, 0);
    ASSERT_EQ(v.size(), size) << "sample " << i;
    (cv::norm(v, image(*lossless.value(), i, 0), cv::NORM_INF) == 0.0 ? exact : from_views)++;
  }
  EXPECT_GE(exact, 20u) << "the first second's frames and the cut view video's tail";
  EXPECT_GE(from_views, 5u) << "the last half second's";
  // Verify counts what the views still hold, and names one that cannot be read; the session is clean.
  const std::string after_cut = view_fact();
  EXPECT_NE(after_cut.find(fmt::format("{} of {} segments", segments.size() - 1, segments.size())), std::string::npos)
      << after_cut;
  EXPECT_NE(after_cut.find("the replay reads the others from the lossless videos"), std::string::npos) << after_cut;
  std::ofstream(st.dir / view_video_path(of_camera_a[0])) << "not a video";
  const std::string unreadable = view_fact();
  EXPECT_NE(unreadable.find(view_video_path(of_camera_a[0]).string() + ": cannot be read"), std::string::npos)
      << unreadable;

  // A store told not to keep them has none.
  const auto without = write_store(temp_root("no-views"), 0.5, true, /*view_videos=*/false);
  EXPECT_FALSE(fs::exists(without.dir / "views"));
  const VerifyReport without_report = verify_session(without.dir);
  EXPECT_NE(format_report(without.dir, without_report).find("view videos: none"), std::string::npos)
      << format_report(without.dir, without_report);
  fs::remove_all(without.dir.parent_path());
  fs::remove_all(root);
}

// docs/store.md's Python example, run as written (extracted from the page) against a store: what it
// prints must be what the C++ reader reads.
TEST(SessionStore, ThePythonExampleInTheDocsReadsWhatTheReaderReads) {
  std::ifstream doc(fs::path(PVCAP_SOURCE_DIR) / "docs/store.md");
  std::stringstream text;
  text << doc.rdbuf();
  const std::string page = text.str();
  const auto section = page.find("## Reading a sample with Python alone");
  ASSERT_NE(section, std::string::npos);
  const auto begin = page.find("```python\n", section);
  const auto end = page.find("```", begin + 10);
  ASSERT_NE(begin, std::string::npos);
  const auto root = temp_root("python");
  const auto st = write_store(root, 2.5, /*raw_first=*/true);  // one raw camera, one colour
  std::ofstream(root / "example.py") << page.substr(begin + 10, end - begin - 10);

  const std::size_t sample = 20;  // in the third segment: the script must find its file and position
  const std::string cmd =
      fmt::format("/usr/bin/python3 {} {} {} 2>&1", (root / "example.py").string(), st.dir.string(), sample);
  FILE* p = popen(cmd.c_str(), "r");
  ASSERT_NE(p, nullptr);
  std::string out;
  char buf[512];
  while (std::size_t n = fread(buf, 1, sizeof buf, p)) out.append(buf, n);
  ASSERT_EQ(pclose(p), 0) << "the example failed (is python3-opencv installed? scripts/deps.sh installs it):\n" << out;

  auto r = SessionReader::open(st.dir);
  ASSERT_TRUE(r);
  auto s = r.value()->sample(sample);
  ASSERT_TRUE(s);
  std::string expected;
  for (std::size_t c = 0; c < r.value()->cameras().size(); ++c) {
    // Sums of every sample value: equal only when the images are (short of a freak compensation).
    const cv::Scalar m = cv::sum(s.value().images[c]);
    expected += fmt::format("{} {}\n", r.value()->cameras()[c].name, std::int64_t(m[0] + m[1] + m[2]));
    if (c == 0) {  // the raw camera: its mosaic as stored, and the image demosaiced from it
      auto mosaic = r.value()->raw_image(sample, c);
      ASSERT_TRUE(mosaic) << mosaic.error().message;
      expected += fmt::format("{} mosaic {}\n", r.value()->cameras()[c].name, std::int64_t(cv::sum(mosaic.value())[0]));
    }
  }
  std::uint64_t total = 0;
  for (auto v : s.value().pressure->counts) total += v;
  expected += fmt::format("pressure {}\n", total);
  EXPECT_EQ(out, expected);
  fs::remove_all(root);
}

// Frames that arrive in a burst (here: 0.3 ms apart, without a mapped time) get distinct
// timestamps in the file; the index says exactly which, so verify and the reader find each one.
TEST(SessionStore, FramesArrivingInABurstAreStillFoundExactly) {
  const auto root = temp_root("burst");
  const auto rig = parse_rig_config(
      "name: burst\ncameras:\n  - {name: c, address: 10.0.0.1}\n"
      "store: {video_codec: ffv1, video_pixel_format: bgr0, min_free_mb: 0, reserve_mb: 0}\n",
      "burst.yaml");
  const std::int64_t t0 = host_now().ns;
  auto w = SessionWriter::create(root, rig, wall_now_ns(), t0);
  ASSERT_TRUE(w);
  const std::int64_t cam = w.value()->add_camera({"camera", "c", "", "", "", "", "", "{}"}, 64, 48).value();
  w.value()->start();
  for (int i = 0; i < 12; ++i) {
    const std::int64_t t = t0 + 1'599'000'000 + i * 300'000;  // 0.3 ms apart: the same millisecond
    FrameRecord f{cam, 0, std::uint64_t(i), std::uint64_t(i), i, t, 0, "good", false, "", {}, {}};
    ASSERT_TRUE(w.value()->submit_video(cam, noise_frame(0, i), f));
    w.value()->record(SampleRecord{std::uint64_t(i), i, t, t, 0, {{cam, 0, std::uint64_t(i), 0}}, {}, {}, {}});
  }
  const auto dir = w.value()->dir();
  ASSERT_TRUE(w.value()->close("test").ok());
  const auto report = verify_session(dir);
  EXPECT_EQ(report.exit_code(), 0) << format_report(dir, report);
  auto r = SessionReader::open(dir);
  ASSERT_TRUE(r);
  for (std::size_t i = 0; i < 12; ++i) {  // backwards: every read is a seek
    const std::size_t k = 11 - i;
    auto img = r.value()->image(k, 0);
    ASSERT_TRUE(img) << img.error().message;
    EXPECT_EQ(cv::norm(img.value(), noise_frame(0, int(k)), cv::NORM_INF), 0) << "sample " << k;
  }
  fs::remove_all(root);
}

// recover never touches a session that is still being recorded.
TEST(SessionStore, RecoverRefusesASessionBeingRecorded) {
  const auto root = temp_root("live");
  const auto rig = parse_rig_config(
      "name: live\ncameras:\n  - {name: c, address: 10.0.0.1}\n"
      "store: {min_free_mb: 0, reserve_mb: 0}\n",
      "live.yaml");
  auto w = SessionWriter::create(root, rig, wall_now_ns(), host_now().ns);
  ASSERT_TRUE(w);
  ASSERT_TRUE(w.value()->add_camera({"camera", "c", "", "", "", "", "", "{}"}, 64, 48));
  w.value()->start();
  auto live = recover_session(w.value()->dir());
  ASSERT_FALSE(live);
  EXPECT_NE(live.error().message.find("being recorded"), std::string::npos) << live.error().message;
  ASSERT_TRUE(w.value()->close("test").ok());
  auto after = recover_session(w.value()->dir());
  ASSERT_TRUE(after) << after.error().message;
  EXPECT_TRUE(after.value().done.empty());
  fs::remove_all(root);
}

// A power cut just after a segment began can keep the segment's file and lose its row in the index
// (and its frames' rows: the journal's unsynced tail). Recover sets such a file aside, never
// overwrites it with the frames of a spill (as it once did: the spill's new segment took the
// number), encodes the spill into a segment of its own, and does it once.
TEST(SessionStore, RecoverSetsAsideASegmentTheIndexLostAndNeverOverwritesIt) {
  const auto root = temp_root("unindexed");
  const auto st = write_store(root, 2.5);
  std::string last;
  {
    sqlite::Database db(st.dir / "session.db", sqlite::Database::Mode::ReadWrite);
    auto q = db.prepare("SELECT id, path FROM video_files WHERE device_id = ? ORDER BY segment DESC LIMIT 1");
    q.bind_all(st.cams[1]);
    ASSERT_TRUE(q.step());
    const std::int64_t id = q.column_int(0);
    last = q.column_text(1);
    q.reset();
    // As the cut left it: no row for the segment, none for its frames or the samples naming them.
    db.prepare(
          "DELETE FROM sample_frames WHERE EXISTS (SELECT 1 FROM frames f WHERE f.device_id = sample_frames.device_id "
          "AND f.connection = sample_frames.connection AND f.sequence = sample_frames.sequence AND f.video_file_id = "
          "?)")
        .bind_all(id)
        .run();
    db.prepare("DELETE FROM frames WHERE video_file_id = ?").bind_all(id).run();
    db.prepare("DELETE FROM video_files WHERE id = ?").bind_all(id).run();
    db.exec("UPDATE session SET ended_host_ns = NULL, end_reason = NULL");
  }
  // And a spill of camB with two frames whose rows were lost too.
  {
    FrameSpillQueue spill(st.dir, "camB", 1, 32, std::chrono::milliseconds(1));
    for (int i = 0; i < 2; ++i) {
      const std::int64_t t = st.t0 + 3'000'000'000 + i * 66'666'667;
      FrameRecord f{st.cams[1], 0, std::uint64_t(100 + i), std::uint64_t(100 + i), 0, t, 0, "good", false, "", {},
                    {},         t};
      ASSERT_TRUE(spill.push(noise_frame(1, 100 + i), f));
    }
    for (int i = 0; i < 200 && spill.on_disk() < 2; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    ASSERT_EQ(spill.on_disk(), 2u);
  }
  const std::string orphan = read_file(st.dir / last);
  const std::string aside = last.substr(0, last.size() - 4) + ".unindexed.mkv";

  auto rec = recover_session(st.dir);
  ASSERT_TRUE(rec) << rec.error().message;
  std::string said;
  for (const auto& d : rec.value().done) said += d + "\n";
  EXPECT_NE(said.find(last + ": on disk but not in the index"), std::string::npos) << said;
  EXPECT_NE(said.find("2 spilled frames encoded"), std::string::npos) << said;
  ASSERT_TRUE(fs::exists(st.dir / aside)) << said;
  EXPECT_EQ(read_file(st.dir / aside), orphan) << "set aside whole";
  EXPECT_TRUE(fs::exists(st.dir / "views" / fs::path(aside).filename())) << "its view copy with it";
  EXPECT_FALSE(fs::exists(st.dir / last)) << "the spill's frames went to a segment of their own";
  {
    sqlite::Database db(st.dir / "session.db", sqlite::Database::Mode::ReadOnly);
    auto q = db.prepare("SELECT count(*) FROM frames WHERE device_id = ? AND sequence >= 100 AND kept = 1");
    q.bind_all(st.cams[1]);
    ASSERT_TRUE(q.step());
    EXPECT_EQ(q.column_int(0), 2) << "the spilled frames have their rows";
  }
  const auto verified = verify_session(st.dir);
  EXPECT_EQ(verified.exit_code(), 3) << format_report(st.dir, verified);
  for (const auto& e : verified.errors) ADD_FAILURE() << e;

  // Once: a second recover finds nothing to do.
  auto again = recover_session(st.dir);
  ASSERT_TRUE(again);
  EXPECT_TRUE(again.value().done.empty());
  fs::remove_all(root);
}
