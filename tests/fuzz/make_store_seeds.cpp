// Writes seeds for fuzz_store_reader: a small real store (two tiny cameras, pressure, samples,
// protocol events) made by SessionWriter, as 'D' + session.db (turned into a rollback-journal
// database so it stands alone) and 'V' + one of its videos. And, for fuzz_store_damage, two small
// stores in the default raw video (a Bayer camera's mosaic, lossless, with capture checksums):
// OUT/raw-finished/ (closed) and OUT/raw-interrupted/ (its writer killed mid-recording: the WAL,
// an unfinished segment, no end), the baselines the fuzzer damages.
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <thread>

#include "codec/sensel_frame.h"
#include "core/rig_config.h"
#include "core/time.h"
#include "storage/index/database.h"
#include "storage/video/frame_checksum.h"
#include "storage/writer/session_writer.h"

namespace fs = std::filesystem;
using namespace pvcap;

namespace {

// A raw store of one Bayer camera (64 x 32, stored in 2 x 2 tiles) and a Sensel; `interrupted`: the process ends without
// closing it (as a kill -9 would), after the index and the segment have been written for a while.
int write_raw_store(const fs::path& out, bool interrupted) {
  const fs::path root = out / "raw-tmp";
  fs::remove_all(root);
  const auto rig = parse_rig_config(
      "name: seed\ncameras:\n  - {name: a, address: 10.0.0.1}\n"
      "store: {video_mode: raw, raw_tiles: 2x2, segment_seconds: 0, min_free_mb: 0, reserve_mb: 0, "
      "sync_interval_s: 0.2}\n",
      "seed.yaml");
  const std::int64_t t0 = host_now().ns;
  auto w = SessionWriter::create(root, rig, wall_now_ns(), t0);
  if (!w) return std::cerr << w.error().message << "\n", 1;
  auto& writer = *w.value();
  const std::int64_t cam = writer.add_camera({"camera", "a", "", "", "", "", "", "{}"}, 64, 32, "BayerRG8").value();
  const std::int64_t sensel = writer.add_device({"sensel", "sensel", "", "", "", "", "", "{}"}).value();
  writer.start();
  for (int i = 0; i < 12; ++i) {
    const std::int64_t t = t0 + 10'000'000 + i * 66'666'667;
    cv::Mat mosaic(32, 64, CV_8UC1);
    cv::randu(mosaic, 0, 255);
    FrameRecord fr{cam, 0, std::uint64_t(i), std::uint64_t(i), i, t, 0, "good", false, "", {}, {}, t};
    fr.checksum = stored_mosaic_crc(mosaic, writer.raw_plane_order(cam));
    writer.submit_video(cam, mosaic, fr);
    sensel::Frame f;
    f.content = sensel::kPressure;
    f.pressure = sensel::PressureImage{3, std::vector<std::uint16_t>(std::size_t(sensel::kMediumDetail.cells()), 0)};
    f.pressure->counts[std::size_t(i * 5)] = std::uint16_t(200 + i);
    PressureRecord r{sensel, 0, std::uint64_t(i), 0, i * 8'000'000, t, 0, 47, 27, 4, 4, sensel::encode_frame(f), t};
    r.base = 3;
    r.counts = f.pressure->counts;
    writer.record(std::move(r));
    writer.record(SampleRecord{std::uint64_t(i),
                               i,
                               t,
                               t,
                               0,
                               {{cam, 0, std::uint64_t(i), 0}},
                               SampleFrameRef{sensel, 0, std::uint64_t(i), 0},
                               SampleFrameRef{sensel, 0, std::uint64_t(i), 0},
                               std::nullopt});
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  const fs::path dir = writer.dir();
  if (interrupted) {
    std::this_thread::sleep_for(std::chrono::milliseconds(800));  // the index committed, the segment written
    std::fflush(nullptr);
    _exit(0);  // no close: what a kill leaves
  }
  if (!writer.close("seed").ok()) return 1;
  w.value().reset();
  const fs::path to = out / "raw-finished";
  fs::remove_all(to);
  fs::rename(dir, to);
  fs::remove_all(root);
  return 0;
}

// The interrupted store is made by a child process that ends without closing it.
int write_interrupted_raw_store(const fs::path& out) {
  const pid_t child = fork();
  if (child < 0) return 1;
  if (child == 0) _exit(write_raw_store(out, true));
  int status = 0;
  waitpid(child, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) return 1;
  const fs::path root = out / "raw-tmp", to = out / "raw-interrupted";
  fs::remove_all(to);
  for (const auto& e : fs::directory_iterator(root)) fs::rename(e.path(), to);
  fs::remove_all(root);
  fs::remove(to / kRecordingLock);  // a lock left by a dead process; the fuzzer's copies need none
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: make_store_seeds OUT_DIR\n";
    return 2;
  }
  const fs::path out = argv[1], root = out / "store";
  fs::remove_all(root);
  fs::create_directories(out);
  const auto rig = parse_rig_config(
      "name: seed\ncameras:\n  - {name: a, address: 10.0.0.1}\n"
      "store: {video_codec: libx264, segment_seconds: 0, min_free_mb: 0, reserve_mb: 0, gop_seconds: 0.5}\n",
      "seed.yaml");
  const std::int64_t t0 = host_now().ns;
  auto w = SessionWriter::create(root, rig, wall_now_ns(), t0);
  if (!w) return std::cerr << w.error().message << "\n", 1;
  auto& writer = *w.value();
  const std::int64_t cam = writer.add_camera({"camera", "a", "", "", "", "", "", "{}"}, 32, 16).value();
  const std::int64_t sensel = writer.add_device({"sensel", "sensel", "", "", "", "", "", "{}"}).value();
  (void)writer.set_participant({"P1", "light", "right_first"});
  writer.start();
  for (int p = 0; p < 40; ++p) {
    sensel::Frame f;
    f.content = sensel::kPressure;
    f.pressure = sensel::PressureImage{3, std::vector<std::uint16_t>(std::size_t(sensel::kMediumDetail.cells()), 0)};
    f.pressure->counts[std::size_t(p * 3)] = std::uint16_t(100 + p);
    PressureRecord r{sensel,
                     0,
                     std::uint64_t(p),
                     0,
                     p * 8'000'000,
                     t0 + p * 8'000'000,
                     0,
                     47,
                     27,
                     4,
                     4,
                     sensel::encode_frame(f),
                     t0 + p * 8'000'000};
    r.base = 3;
    r.counts = f.pressure->counts;
    writer.record(std::move(r));
  }
  for (int i = 0; i < 4; ++i) {
    const std::int64_t t = t0 + 10'000'000 + i * 66'666'667;
    writer.submit_video(cam, cv::Mat(16, 32, CV_8UC3, cv::Scalar(i * 40, 80, 200 - i * 30)),
                        FrameRecord{cam, 0, std::uint64_t(i), std::uint64_t(i), i, t, 0, "good", false, "", {}, {}, t});
    const std::uint64_t before = std::uint64_t((t - t0) / 8'000'000);
    writer.record(SampleRecord{std::uint64_t(i),
                               i,
                               t,
                               t,
                               0,
                               {{cam, 0, std::uint64_t(i), 0}},
                               SampleFrameRef{sensel, 0, before, -1000},
                               SampleFrameRef{sensel, 0, before, -1000},
                               SampleFrameRef{sensel, 0, before + 1, 7000}});
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  writer.record(ProtocolEventRecord{t0, "action_start", 1, "press", "right", "high", 1, ""});
  writer.record(ProtocolEventRecord{t0 + 200'000'000, "action_end", 1, "press", "right", "high", 1, ""});
  const fs::path dir = writer.dir();
  if (!writer.close("seed").ok()) return 1;
  w.value().reset();  // the writer's connection goes before the journal mode can change
  {
    sqlite::Database db(dir / "session.db", sqlite::Database::Mode::ReadWrite);
    db.exec("PRAGMA journal_mode=DELETE");
    db.exec("VACUUM");
  }
  auto seed = [&](const fs::path& from, const fs::path& to, char tag) {
    std::ifstream in(from, std::ios::binary);
    std::ofstream o(to, std::ios::binary);
    o.put(tag);
    o << in.rdbuf();
  };
  seed(dir / "session.db", out / "seed-db", 'D');
  seed(dir / "session.db", out / "seed-replay", 'R');
  seed(dir / "a-000.mkv", out / "seed-video", 'V');
  fs::remove_all(root);
  // Forked once the first store's writer and its threads are gone (a fork copies only the caller).
  if (write_interrupted_raw_store(out) != 0) return std::cerr << "the interrupted raw store failed\n", 1;
  if (write_raw_store(out, false) != 0) return 1;
  seed(out / "raw-finished" / "a-000.mkv", out / "seed-video-tiled", 'V');  // a raw video in tiles
  return 0;
}
