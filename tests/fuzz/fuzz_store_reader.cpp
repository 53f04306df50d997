// libFuzzer target: the store's readers on damaged input. The first byte picks what the rest is:
// 'D' a session.db (read through SessionReader: every sample, pressure frame and total, action,
// event, drop, clock model and statistic), 'R' a session.db read to be re-served through the
// devices (sim::SessionReplay, and the rig file `pvcap replay --as-devices` writes from it), 'V' a
// video file (VideoReader: open, random access, sequential decoding). Any bytes give data or an
// Error with a message; never a crash, a hang or an exception.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "sim/replay_rig.h"
#include "sim/session_replay.h"
#include "storage/index/session_reader.h"
#include "storage/video/video_reader.h"
#include "tests/fuzz/fuzz_scratch.h"

namespace {
const std::filesystem::path& scratch() { return pvcap::fuzz::scratch("store"); }

void write_file(const std::filesystem::path& p, const std::uint8_t* data, std::size_t size) {
  for (const char* suffix : {"", "-wal", "-shm", "-journal"}) std::filesystem::remove(p.string() + suffix);
  std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(data), std::streamsize(size));
}

void read_store(const std::filesystem::path& dir) {
  auto r = pvcap::SessionReader::open(dir);
  if (!r) {
    if (r.error().message.empty()) __builtin_trap();
    return;
  }
  auto& reader = *r.value();
  for (std::size_t i = 0; i < reader.sample_count() && i < 64; ++i) {
    auto s = reader.sample(i, i % 2 ? pvcap::PressureMode::Interpolated : pvcap::PressureMode::Nearest);
    if (!s && s.error().message.empty()) __builtin_trap();
    (void)reader.sample_at(std::int64_t(i) * 66'000'000);
  }
  (void)reader.pressure_frame(0);
  (void)reader.pressure_frames_between(INT64_MIN / 2, INT64_MAX / 2);
  (void)reader.pressure_totals();
  (void)reader.sample_infos();
  (void)reader.drops();
  (void)reader.clock_models();
  (void)reader.timeline_counts();
  (void)reader.protocol_events();
  for (const auto& c : reader.cameras()) (void)reader.frame_timing(c.device_id);
  (void)reader.actions();
  (void)reader.events();
  (void)reader.operator_notes();
  (void)reader.calibrations();
  (void)reader.stream_statistics();
}

void read_replay(const std::filesystem::path& dir) {
  auto r = pvcap::sim::SessionReplay::open(dir);
  if (!r) {
    if (r.error().message.empty()) __builtin_trap();
    return;
  }
  auto& replay = *r.value();
  (void)replay.start(1'000'000'000);
  for (std::size_t c = 0;; ++c) {
    auto i = replay.camera_index("cam" + std::to_string(c));
    if (!i) break;
    for (const auto& f : replay.camera_frames(i.value()))
      (void)replay.camera_device_time(i.value(), replay.due_ns(f.t_ns));
  }
  auto rig = pvcap::sim::write_replay_rig(dir, dir / "replay.yaml", 1.0);
  if (!rig && rig.error().message.empty()) __builtin_trap();
}

void read_video(const std::filesystem::path& path) {
  auto v = pvcap::VideoReader::open(path);
  if (!v) return;
  cv::Mat bgr;
  (void)v.value()->read_at(200, bgr);
  (void)v.value()->read_at(0, bgr);
  std::int64_t pts = 0;
  for (int n = 0; n < 32; ++n) {
    auto more = v.value()->next(bgr, pts);
    if (!more || !more.value()) break;
  }
  // A region of a raw frame: a tiled video decodes the tiles under it.
  if (v.value()->raw() && v.value()->width() >= 4 && v.value()->height() >= 4) {
    cv::Mat region;
    (void)v.value()->read_raw_region_at(0, {2, 2, (v.value()->width() / 2) & ~1, (v.value()->height() / 2) & ~1},
                                        region);
    (void)v.value()->read_raw_region_at(200, {0, 0, 2, 2}, region);
  }
  // A viewer's reader: a green-last HuffYUV video's decoder told the picture is 3/4 as tall.
  pvcap::VideoReader::Options views;
  views.half_size_colour_only = true;
  auto viewer = pvcap::VideoReader::open(path, views);
  if (!viewer) return;
  viewer.value()->set_demosaic(pvcap::Demosaic::HalfSize);
  (void)viewer.value()->read_at(200, bgr);
  // At a third of the mosaic's size: two thirds of half size, made straight from the planes.
  viewer.value()->set_image_size({std::max(1, viewer.value()->width() / 3), std::max(1, viewer.value()->height() / 3)});
  for (int n = 0; n < 32; ++n) {
    auto more = viewer.value()->next(bgr, pts);
    if (!more || !more.value()) break;
  }
  cv::Mat mosaic;
  (void)viewer.value()->read_raw_at(0, mosaic);  // refused, not crashed, by a three-plane reader
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  if (data[0] == 'D') {
    write_file(scratch() / "session.db", data + 1, size - 1);
    read_store(scratch());
  } else if (data[0] == 'R') {
    write_file(scratch() / "session.db", data + 1, size - 1);
    read_replay(scratch());
  } else if (data[0] == 'V') {
    write_file(scratch() / "video.mkv", data + 1, size - 1);
    read_video(scratch() / "video.mkv");
  }
  return 0;
}
