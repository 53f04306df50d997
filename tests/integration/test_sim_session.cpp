// End-to-end: the real `pvcap session` records the simulated GigE rig, and the
// store is checked against the simulator's ground truth.
#include <gtest/gtest.h>

#include <cstdio>

#include <fmt/format.h>

#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>
#include "codec/sensel_frame.h"
#include "core/sequence_unwrap.h"
#include "session_under_test.h"
#include "sim/timecode.h"
#include "storage/index/database.h"
#include "storage/video/video_reader.h"

#include "codec/sensel_units.h"
#include "sim/fingertip.h"
#include "sim/truth.h"

using namespace pvcap::testing;
namespace fs = std::filesystem;

namespace {

constexpr int kWidth = 640, kHeight = 360;
constexpr double kFps = 60;

using Key = std::pair<std::uint64_t, std::int64_t>;  // (frame id, device timestamp): unique within a run

struct Accounting {
  std::size_t emitted_in_span = 0, indexed = 0, dropped = 0, unaccounted = 0, before_first = 0;
};

// Every frame the simulator emitted, from the first to the last one pvcap received, must be
// in the index or inside a drop range; and every index row must be a frame the simulator emitted
// (same id, same device timestamp).
Accounting account(const CameraRecord& c) {
  Accounting a;
  std::map<Key, std::size_t> truth_pos;
  for (std::size_t i = 0; i < c.truth.size(); ++i) truth_pos[{c.truth[i].frame_id, c.truth[i].device_ns}] = i;
  std::set<std::uint64_t> indexed_seqs;
  std::size_t first = SIZE_MAX, last = 0;
  for (const auto& f : c.frames) {
    // Buffers Aravis delivered without their own leader carry no (or a stale) identity: they
    // must be incomplete and not stored; the frame they were is accounted for in a gap.
    if (f.reason.rfind("no_frame_id", 0) == 0 || f.reason.rfind("stale_metadata", 0) == 0) {
      EXPECT_NE(f.status, "good") << c.name;
      EXPECT_FALSE(f.kept) << c.name;
      continue;
    }
    auto it = truth_pos.find({f.frame_id, f.device_ns});
    EXPECT_NE(it, truth_pos.end()) << c.name << ": index frame id " << f.frame_id << " at device " << f.device_ns
                                   << " was never emitted";
    if (it == truth_pos.end()) continue;
    first = std::min(first, it->second);
    last = std::max(last, it->second);
    indexed_seqs.insert(f.sequence);
  }
  // A frame is either in the index or dropped, never both.
  for (const auto& d : c.drops)
    for (std::uint64_t q = d.first_sequence; q < d.first_sequence + d.count; ++q)
      EXPECT_EQ(indexed_seqs.count(q), 0u) << c.name << ": sequence " << q << " is both indexed and dropped";
  if (first == SIZE_MAX) return a;
  a.before_first = first;
  // Number the truth like the recorder numbers what it receives: the first received id is its own sequence.
  pvcap::SequenceUnwrapper unwrap(16, true);
  for (std::size_t i = first; i <= last; ++i) {
    const std::uint64_t seq = unwrap.next(c.truth[i].frame_id).sequence;
    ++a.emitted_in_span;
    if (indexed_seqs.count(seq)) {
      ++a.indexed;
      continue;
    }
    bool in_drop = false;
    for (const auto& d : c.drops)
      if (seq >= d.first_sequence && seq < d.first_sequence + d.count && !d.reason.empty()) in_drop = true;
    if (in_drop)
      ++a.dropped;
    else
      ++a.unaccounted;
  }
  return a;
}

struct VideoCheck {
  std::size_t decoded = 0, timecode_ok = 0, stripe_ok = 0;
};

// Decodes the camera's video and checks each frame against its index row and the truth.
VideoCheck check_video(const fs::path& session, const CameraRecord& c) {
  VideoCheck v;
  std::map<std::pair<std::int64_t, std::int64_t>, const IndexFrame*> by_video_index;  // (file, position)
  for (const auto& f : c.frames)
    if (f.kept) by_video_index[{f.video_file_id, f.video_index}] = &f;
  std::map<Key, std::int64_t> true_time;
  for (const auto& t : c.truth) true_time[{t.frame_id, t.device_ns}] = t.true_ns;
  EXPECT_FALSE(c.videos.empty()) << c.name << " has no video file in " << session;
  for (const auto& [file_id, path] : c.videos) {
    auto reader = pvcap::VideoReader::open(path);
    EXPECT_TRUE(reader) << (reader ? "" : reader.error().message);
    if (!reader) return v;
    cv::Mat img;
    std::int64_t pts_ms = 0;
    for (std::int64_t n = 0;; ++n) {
      auto more = reader.value()->next(img, pts_ms);
      if (!more || !more.value()) break;
      ++v.decoded;
      auto row = by_video_index.find({file_id, n});
      if (row == by_video_index.end()) {
        ADD_FAILURE() << c.name << ": video frame " << n << " has no index row";
        continue;
      }
      const auto tc = pvcap::sim::read_timecode(img);
      const auto truth = true_time.find({row->second->frame_id, row->second->device_ns});
      if (tc && tc->frame_id == row->second->frame_id && truth != true_time.end() && tc->true_ns == truth->second)
        ++v.timecode_ok;
      else
        // Seen once in ~36 runs beside a fuzzer (2026-11-26): a frame after the reconnection whose row
        // and pixels both belong to an instant 4.8 s earlier (id 9, before the camera vanished) and
        // which the truth does not list. Everything known about it is said.
        ADD_FAILURE() << c.name << ": video frame " << n << " timecode does not match its index row (frame id "
                      << row->second->frame_id << ", connection " << row->second->connection << ", device_ns "
                      << row->second->device_ns << ", arrived " << row->second->host_ns << ", status "
                      << row->second->status << "; decoded "
                      << (tc ? fmt::format("id {} true {}", tc->frame_id, tc->true_ns) : std::string("nothing"))
                      << "; the truth's rows of that id: " <<
            [&] {
              std::string rows;
              for (const auto& t : c.truth)
                if (t.frame_id == row->second->frame_id)
                  rows += fmt::format("[device {} true {}] ", t.device_ns, t.true_ns);
              return rows;
            }() << "; the truth's "
                      << c.truth.size() << " rows from true " << (c.truth.empty() ? 0 : c.truth.front().true_ns)
                      << " to " << (c.truth.empty() ? 0 : c.truth.back().true_ns)
                      << ", those within 70 ms of the decoded instant: " <<
            [&] {
              std::string rows;
              if (tc)
                for (const auto& t : c.truth)
                  if (std::llabs(t.true_ns - tc->true_ns) < 70'000'000)
                    rows += fmt::format("[id {} device {} true {}] ", t.frame_id, t.device_ns, t.true_ns);
              return rows;
            }()
                      << "; other cameras' truth rows of that id and device time: " <<
            [&] {
              // Is it another camera's frame? (The simulated cameras share a clock function.)
              std::string found;
              for (const auto& e : fs::directory_iterator(session / "sim-truth")) {
                const std::string file = e.path().filename().string();
                if (file == c.name + "_frames.csv" || file.find("_frames.csv") == std::string::npos) continue;
                std::ifstream in(e.path());
                std::string line;
                while (std::getline(in, line)) {
                  unsigned id = 0;
                  long long true_ns = 0, device_ns = 0;
                  if (std::sscanf(line.c_str(), "%u,%lld,%lld", &id, &true_ns, &device_ns) == 3 &&
                      id == row->second->frame_id && device_ns == row->second->device_ns)
                    found += fmt::format("[{} true {}] ", file, true_ns);
                }
              }
              return found.empty() ? std::string("none") : found;
            }()
                      << "; the index rows around it: " <<
            [&] {
              std::string rows;
              for (std::int64_t k = std::max<std::int64_t>(0, n - 2); k <= n + 2; ++k)
                if (auto r = by_video_index.find({file_id, k}); r != by_video_index.end())
                  rows += fmt::format("[#{} conn {} id {} device {} arrived {}] ", k, r->second->connection,
                                      r->second->frame_id, r->second->device_ns, r->second->host_ns);
              return rows;
            }() << ")";
      if (pvcap::sim::frame_stripe_mismatches(img, std::uint16_t(row->second->frame_id)) == 0)
        ++v.stripe_ok;
      else
        ADD_FAILURE() << c.name << ": video frame " << n << " holds pixels of another frame (corrupted)";
    }
  }
  return v;
}

}  // namespace

TEST(SimSession, FourCamerasTenSecondsEveryFrameAccountedAndTimecodesMatch) {
  const double duration = 10;
  const auto s = record("four",
                        sim_rig_yaml({{.drift_ppm = 40, .offset_ms = 5000},
                                      {.drift_ppm = -65, .offset_ms = 12500},
                                      {.drift_ppm = 90, .offset_ms = 800},
                                      {.drift_ppm = -15, .offset_ms = 31000}},
                                     kWidth, kHeight, kFps, 15),
                        duration);
  ASSERT_EQ(s.result.exit_code, 0) << s.result.output;
  ASSERT_FALSE(s.dir.empty()) << s.result.output;
  ASSERT_EQ(s.cameras.size(), 4u);
  {  // the report printed at the end is also kept beside the data
    std::ifstream in(s.dir / "report.txt");
    std::stringstream report;
    report << in.rdbuf();
    EXPECT_NE(report.str().find("ended: duration reached"), std::string::npos) << report.str();
    EXPECT_NE(s.result.output.find(report.str()), std::string::npos) << "report.txt differs from what was printed";
  }
  for (const auto& c : s.cameras) {
    SCOPED_TRACE(c.name);
    ASSERT_FALSE(c.truth.empty());
    EXPECT_GT(double(c.frames.size()), 0.8 * duration * kFps);
    const Accounting a = account(c);
    EXPECT_EQ(a.unaccounted, 0u) << "of " << a.emitted_in_span << " emitted frames";
    EXPECT_EQ(a.before_first, 0u) << "the first emitted frames never arrived and were not counted";
    // The simulated ids start near 65535, so every run crosses the GigE Vision wrap (65535 -> 1).
    EXPECT_GT(c.frames.back().sequence, 65535u);
    std::map<Key, std::int64_t> true_time;
    for (const auto& t : c.truth) true_time[{t.frame_id, t.device_ns}] = t.true_ns;
    std::size_t kept = 0;
    for (const auto& f : c.frames) {
      const std::int64_t latency = f.host_ns - true_time[{f.frame_id, f.device_ns}];
      EXPECT_GT(latency, 0) << "arrival before capture, frame " << f.frame_id;
      EXPECT_LT(latency, 1'000'000'000) << "frame " << f.frame_id;
      if (f.kept)
        ++kept;
      else
        EXPECT_FALSE(f.reason.empty()) << "frame " << f.frame_id << " not kept, without a reason";
    }
    EXPECT_NEAR(double(kept), duration * 15, duration * 15 * 0.15);  // the 15 Hz grid
    const VideoCheck v = check_video(s.dir, c);
    EXPECT_EQ(v.decoded, kept);
    EXPECT_EQ(v.timecode_ok, kept);
    EXPECT_EQ(v.stripe_ok, kept);
  }
}

TEST(SimSession, OnePercentPacketLossNeverStoresACorruptedFrame) {
  const auto s =
      record("loss", sim_rig_yaml({{.packet_loss = 0.01}, {.packet_loss = 0.01}}, kWidth, kHeight, kFps, 0), 6);
  ASSERT_EQ(s.result.exit_code, 0) << s.result.output;
  ASSERT_EQ(s.cameras.size(), 2u);
  std::size_t incomplete = 0;
  for (const auto& c : s.cameras) {
    SCOPED_TRACE(c.name);
    std::size_t kept = 0;
    for (const auto& f : c.frames) {
      if (f.status != "good") {
        ++incomplete;
        EXPECT_FALSE(f.kept) << "incomplete frame " << f.frame_id << " was stored";
        EXPECT_FALSE(f.reason.empty());
      }
      if (f.kept) ++kept;
    }
    const Accounting a = account(c);
    EXPECT_EQ(a.unaccounted, 0u) << "of " << a.emitted_in_span;
    // Every frame in the video (all good frames are kept here) is intact and is the frame the index says.
    const VideoCheck v = check_video(s.dir, c);
    EXPECT_EQ(v.decoded, kept);
    EXPECT_EQ(v.stripe_ok, kept);
    EXPECT_EQ(v.timecode_ok, kept);
  }
  EXPECT_GT(incomplete, 0u) << "the injected loss never hit a frame: the test proves nothing";
  // Aravis' own statistics were recorded.
  pvcap::sqlite::Database db(s.dir / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
  auto q = db.prepare("SELECT sum(failures), sum(completed) FROM stream_stats");
  ASSERT_TRUE(q.step());
  EXPECT_GT(q.column_int(0), 0);
  EXPECT_GT(q.column_int(1), 0);
}

TEST(SimSession, KilledCameraIsReportedWithinTwoSecondsAndTheOthersKeepRecording) {
  const double duration = 8;
  const auto s = record("kill", sim_rig_yaml({{}, {}, {.stop_after_s = 3.0}, {}}, kWidth, kHeight, 30, 15), duration);
  ASSERT_EQ(s.result.exit_code, 0) << s.result.output;
  EXPECT_NE(s.result.output.find("cam2 (serial PVSIM2 at 127.0.0.4): camera lost"), std::string::npos)
      << s.result.output;
  ASSERT_EQ(s.cameras.size(), 4u);
  const auto& dead = s.cameras[2];
  ASSERT_FALSE(dead.truth.empty());
  const std::int64_t vanished_ns = dead.truth.back().true_ns;  // its last frame

  pvcap::sqlite::Database db(s.dir / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
  auto q = db.prepare("SELECT min(host_ns) FROM events WHERE kind = 'camera_lost' AND device_id = ?");
  q.bind(1, dead.device_id);
  ASSERT_TRUE(q.step());
  ASSERT_FALSE(q.column_null(0)) << "no camera_lost event stored";
  const std::int64_t reported_after = q.column_int(0) - vanished_ns;
  EXPECT_GT(reported_after, 0);
  EXPECT_LE(reported_after, 2'000'000'000) << "reported " << reported_after / 1e6 << " ms after the camera vanished";

  for (std::size_t i : {0u, 1u, 3u}) {
    const auto& c = s.cameras[i];
    SCOPED_TRACE(c.name);
    ASSERT_FALSE(c.frames.empty());
    // Still recording at the end: frames until well after the loss, at the full rate.
    EXPECT_GT(c.frames.back().host_ns - vanished_ns, 3'000'000'000);
    EXPECT_GT(double(c.frames.size()), 0.8 * duration * 30);
    EXPECT_EQ(account(c).unaccounted, 0u);
  }
  // The stop does not wait on the lost camera: closing its connection waits on GVCP's timeouts (10 s
  // in Aravis 0.8.26), so it is done in the background; the session closes as one without a loss does.
  auto ended = db.prepare("SELECT ended_host_ns FROM session");
  ASSERT_TRUE(ended.step());
  const std::int64_t close_ns = ended.column_int(0) - s.cameras[0].frames.back().host_ns;
  std::printf("session closed %.0f ms after its last frame\n", double(close_ns) / 1e6);
  EXPECT_LT(close_ns, 3'000'000'000) << "the stop waited on the lost camera";
}

// Cameras on a trigger line (the simulator's line pulses at the configured 30 Hz, every camera at
// the same instants). One vanishes: it sends nothing, as a camera whose trigger stopped would, but it
// no longer answers either, and is reported lost within 2 s. Another is not wired to the line: it
// answers, so the operator is told no trigger reaches it, and it is not called lost.
TEST(SimSession, AHardwareTriggeredCameraThatVanishesIsReportedWithinTwoSeconds) {
  const double duration = 7;
  const auto s = record(
      "hwtrigger",
      sim_rig_yaml({{}, {}, {.stop_after_s = 3.0}, {.trigger_line = false}}, kWidth, kHeight, 30, 15, "hardware"),
      duration);
  ASSERT_EQ(s.result.exit_code, 0) << s.result.output;
  ASSERT_EQ(s.cameras.size(), 4u);
  EXPECT_NE(s.result.output.find("cam2 (serial PVSIM2 at 127.0.0.4): camera lost (no frame for"), std::string::npos)
      << s.result.output;
  EXPECT_NE(s.result.output.find("cam3 (serial PVSIM3 at 127.0.0.5): no frame for"), std::string::npos)
      << s.result.output;
  pvcap::sqlite::Database db(s.dir / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
  auto events = [&](const char* kind, std::int64_t device) {
    auto q = db.prepare("SELECT count(*), min(host_ns) FROM events WHERE kind = ? AND device_id = ?");
    q.bind_all(std::string(kind), device);
    EXPECT_TRUE(q.step());
    return std::pair{q.column_int(0), q.column_null(1) ? std::int64_t(0) : q.column_int(1)};
  };
  const auto& dead = s.cameras[2];
  ASSERT_FALSE(dead.truth.empty());
  const std::int64_t vanished_ns = dead.truth.back().true_ns;  // its last frame
  const auto [lost, lost_at] = events("camera_lost", dead.device_id);
  ASSERT_EQ(lost, 1) << "no camera_lost event stored";
  EXPECT_GT(lost_at - vanished_ns, 0);
  EXPECT_LE(lost_at - vanished_ns, 2'000'000'000) << "reported " << (lost_at - vanished_ns) / 1e6 << " ms after";
  std::printf("hardware-triggered camera reported lost %.0f ms after its last frame\n",
              double(lost_at - vanished_ns) / 1e6);
  EXPECT_EQ(events("camera_no_trigger", dead.device_id).first, 0) << "it did not answer: lost, not untriggered";
  // Not wired: told once, never lost, no frames.
  EXPECT_EQ(events("camera_no_trigger", s.cameras[3].device_id).first, 1);
  EXPECT_EQ(events("camera_lost", s.cameras[3].device_id).first, 0);
  EXPECT_TRUE(s.cameras[3].frames.empty());
  // The two on the line record at its rate, triggered together: their frames group into complete pairs.
  for (std::size_t i : {0u, 1u}) {
    SCOPED_TRACE(s.cameras[i].name);
    EXPECT_GT(double(s.cameras[i].frames.size()), 0.8 * duration * 30);
    EXPECT_EQ(events("camera_no_trigger", s.cameras[i].device_id).first, 0);
    EXPECT_EQ(account(s.cameras[i]).unaccounted, 0u);
  }
  // Each sample holds the frames of one pulse, and its span is the one the frames truly had. (How far
  // apart the simulated cameras take one pulse's frames is the simulator's: each engine looks for the
  // pending trigger within 1/120 s of the pulse, and a loaded machine adds its own delays: 97-98 of
  // 99-100 under 5 ms alone, 81 of 106 in a slow CI run. What pvcap answers for is grouping them and
  // stating their span, so that is what is held here, against the truth.)
  std::map<std::pair<std::int64_t, std::uint64_t>, std::int64_t> true_ns;  // (device, sequence) -> true instant
  for (const auto& cam : s.cameras) {
    std::map<std::uint16_t, std::int64_t> by_id;
    for (const auto& t : cam.truth) by_id[t.frame_id] = t.true_ns;
    for (const auto& f : cam.frames)
      if (auto it = by_id.find(std::uint16_t(f.frame_id)); it != by_id.end())
        true_ns[{cam.device_id, f.sequence}] = it->second;
  }
  auto q = db.prepare(
      "SELECT s.id, s.span_ns, sf.device_id, sf.sequence FROM samples s JOIN sample_frames sf ON sf.sample_id = s.id "
      "WHERE s.cameras >= 2 ORDER BY s.id");
  std::map<std::int64_t, std::pair<std::int64_t, std::vector<std::int64_t>>> samples;  // id -> (span, true instants)
  while (q.step()) {
    auto& entry = samples[q.column_int(0)];
    entry.first = q.column_int(1);
    const auto it = true_ns.find({q.column_int(2), std::uint64_t(q.column_int(3))});
    if (it != true_ns.end()) entry.second.push_back(it->second);
  }
  EXPECT_GT(samples.size(), 60u);
  std::size_t compared = 0, one_pulse = 0, span_true = 0, under_5ms = 0;
  for (const auto& [id, entry] : samples) {
    const auto& [span, instants] = entry;
    if (instants.size() < 2) continue;
    ++compared;
    const auto [lo, hi] = std::minmax_element(instants.begin(), instants.end());
    const std::int64_t true_span = *hi - *lo;
    one_pulse += true_span < 1'000'000'000 / 60;  // half the line's period
    span_true += std::llabs(span - true_span) <= 1'000'000;
    under_5ms += true_span < 5'000'000;
  }
  std::printf(
      "samples with two or more cameras: %zu; frames of one pulse in %zu; span within 1 ms of the true one in %zu; "
      "truly under 5 ms in %zu\n",
      samples.size(), one_pulse, span_true, under_5ms);
  EXPECT_EQ(compared, samples.size()) << "a sample's frames missing from the simulator's truth";
  EXPECT_EQ(one_pulse, compared) << "a sample holds frames of two pulses";
  EXPECT_GE(span_true * 100, compared * 95) << "the stored span is the frames' true one";
}

TEST(SimSession, CameraThatComesBackIsReconnectedAndRecordsAgain) {
  // cam1 vanishes 2 s after the simulator starts and is back (power-cycled) 3 s later.
  const auto s = record("reconnect",
                        sim_rig_yaml({{}, {.stop_after_s = 2.0, .return_after_s = 5.0}}, kWidth, kHeight, 30, 15), 11);
  ASSERT_EQ(s.result.exit_code, 0) << s.result.output;
  EXPECT_NE(s.result.output.find("cam1 (serial PVSIM1 at 127.0.0.3): reconnected"), std::string::npos)
      << s.result.output;
  ASSERT_EQ(s.cameras.size(), 2u);
  const auto& c = s.cameras[1];
  std::size_t before = 0, after = 0, kept_after = 0;
  for (const auto& f : c.frames) {
    if (f.connection == 0)
      ++before;
    else {
      ++after;
      if (f.kept) ++kept_after;
    }
  }
  EXPECT_GT(before, 10u);
  EXPECT_GT(after, 30u) << "no frames after the reconnection";
  EXPECT_GT(kept_after, 5u) << "frames after the reconnection did not reach the video";
  pvcap::sqlite::Database db(s.dir / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
  auto q = db.prepare(
      "SELECT group_concat(kind) FROM (SELECT kind FROM events WHERE device_id = ? AND kind LIKE 'camera_%' ORDER BY "
      "host_ns)");
  q.bind(1, c.device_id);
  ASSERT_TRUE(q.step());
  EXPECT_EQ(q.column_text(0), "camera_lost,camera_reconnected");
  // The video holds both connections' frames, each the frame its index row names.
  const VideoCheck v = check_video(s.dir, c);
  EXPECT_GT(v.decoded, 0u);
  EXPECT_EQ(v.timecode_ok, v.decoded);
}

// Four identical cameras (one region, one pixel format: the rig labs build), cam1 unplugged and back
// 20 times while the other three stream at 60 Hz. A stream made while others stream takes its
// packets on a UDP port of its own (capture/aravis_stream.h, StreamSocket): no other camera's frame
// can reach it, so every frame stored under a camera's name is that camera's, by the simulator's
// per-camera truth (its id, device time and the true instant drawn into its pixels).
TEST(SimSession, FourIdenticalCamerasOneReconnectedTwentyTimesStoreOnlyTheirOwnFrames) {
  constexpr int kOutages = 20;
  constexpr double kEvery = 2.5, kFirst = 2.0, kOutage = 0.4;
  const double duration = kFirst + (kOutages - 1) * kEvery + kOutage + 2.5;
  std::vector<SimCameraSpec> cams(4);
  for (std::size_t i = 0; i < cams.size(); ++i) cams[i].offset_ms = 1000 + 7919.0 * double(i);
  cams[1].stop_after_s = kFirst;
  cams[1].return_after_s = kFirst + kOutage;
  cams[1].outages = kOutages;
  cams[1].outage_every_s = kEvery;
  const auto s = record("identical-reconnect", sim_rig_yaml(cams, 320, 240, 60, 0), duration);
  ASSERT_EQ(s.result.exit_code, 0) << s.result.output;
  ASSERT_EQ(s.cameras.size(), 4u);
  // Every reconnection, each on a stream of its own UDP port (the others were streaming).
  std::size_t own_port = 0;
  for (auto at = s.result.output.find("cam1 (serial PVSIM1 at 127.0.0.3): 3 other camera(s) streaming: this stream "
                                      "takes its packets on a UDP port of its own");
       at != std::string::npos; at = s.result.output.find("this stream takes its packets on a UDP port", at + 1))
    ++own_port;
  pvcap::sqlite::Database db(s.dir / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
  auto q = db.prepare("SELECT count(*) FROM events WHERE device_id = ? AND kind = 'camera_reconnected'");
  q.bind(1, s.cameras[1].device_id);
  ASSERT_TRUE(q.step());
  EXPECT_EQ(q.column_int(0), kOutages) << s.result.output;
  // (A reconnection whose camera went again between its stream and its start makes one more.)
  EXPECT_GE(own_port, std::size_t(kOutages)) << "a reconnection's stream on a packet socket";
  // Each camera's rows name only frames its own camera sent; each stored picture is the frame its row
  // names, by the instant the simulator drew into it.
  std::map<Key, std::string> sent_by;
  for (const auto& c : s.cameras)
    for (const auto& t : c.truth) sent_by[{t.frame_id, t.device_ns}] += c.name;
  for (const auto& c : s.cameras) {
    SCOPED_TRACE(c.name);
    std::size_t good = 0, foreign = 0;
    for (const auto& f : c.frames) {
      if (f.status != "good") continue;
      ++good;
      const auto who = sent_by.find({f.frame_id, f.device_ns});
      if (who == sent_by.end() || who->second != c.name) {
        ++foreign;
        ADD_FAILURE() << "frame id " << f.frame_id << " device_ns " << f.device_ns << " (connection " << f.connection
                      << ") was sent by " << (who == sent_by.end() ? std::string("no camera") : who->second);
      }
    }
    EXPECT_GT(good, std::size_t(c.name == "cam1" ? 20 * kOutages : 50 * duration)) << "too few frames to tell";
    EXPECT_EQ(foreign, 0u);
    const VideoCheck v = check_video(s.dir, c);
    EXPECT_GT(v.decoded, 0u);
    EXPECT_EQ(v.timecode_ok, v.decoded) << "a stored picture is not the frame its row names";
    std::printf("%s: %zu good frames, %zu decoded from its videos, all its own\n", c.name.c_str(), good, v.decoded);
  }
}

TEST(SimSession, SoftwareTriggeredCameraDeliversAtTheConfiguredRate) {
  const double duration = 4, fps = 20;
  const auto s = record("swtrigger", sim_rig_yaml({{}}, kWidth, kHeight, fps, 0, "software"), duration);
  ASSERT_EQ(s.result.exit_code, 0) << s.result.output;
  ASSERT_EQ(s.cameras.size(), 1u);
  EXPECT_NEAR(double(s.cameras[0].frames.size()), duration * fps, duration * fps * 0.2);
  EXPECT_EQ(s.result.output.find("camera lost"), std::string::npos) << s.result.output;
}

// An encoder slower than its camera on any machine (it waits 60 ms before each frame, a fault of
// core/fault_injection.h, so it manages ~16 of the camera's 30 frames/s; every frame kept): the
// operator is told once that frames wait on disk, and not one frame is lost for it.
TEST(SimSession, AnEncoderFallingBehindIsWarnedOnceAndItsFramesWaitOnDisk) {
  std::string rig = sim_rig_yaml({{}}, 1280, 720, 30, 0);
  const auto at = rig.find("  preset: ultrafast\n");
  ASSERT_NE(at, std::string::npos) << rig;
  rig.replace(at, std::string("  preset: ultrafast\n").size(),
              "  video_mode: color\n  preset: ultrafast\n  queue_frames: 2\n");
  setenv("PVCAP_FAULTS", "encoder.frame_delay_ms=60", 1);
  const auto s = record("encoder_behind", rig, 3);
  unsetenv("PVCAP_FAULTS");
  ASSERT_EQ(s.result.exit_code, 0) << s.result.output;
  const std::string warning = "frames wait on disk (the spill)";
  const auto first = s.result.output.find(warning);
  ASSERT_NE(first, std::string::npos) << s.result.output;
  EXPECT_EQ(s.result.output.find(warning, first + 1), std::string::npos) << "warned more than once";
  EXPECT_NE(s.result.output.find("waiting frames encoded in"), std::string::npos) << s.result.output;
  ASSERT_EQ(s.cameras.size(), 1u);
  std::size_t lost_to_the_store = 0, in_video = 0;
  for (const auto& f : s.cameras[0].frames) {
    lost_to_the_store +=
        f.reason == "encoder_behind" || f.reason.rfind("spill", 0) == 0 || f.reason == "video_write_failed";
    in_video += f.video_index >= 0;
  }
  EXPECT_EQ(lost_to_the_store, 0u);
  EXPECT_GT(in_video, 60u);
  EXPECT_FALSE(fs::exists(s.dir / "spill"));
}

// A camera worker that falls behind (stalled 1.5 s on purpose, core/fault_injection.h) loses frames
// with their true reason, says so once, and every frame stays accounted for.
struct BehindOutcome {
  std::map<std::string, std::uint64_t> lost_by_reason;  // camera 0's drop rows
  Accounting accounting;
  std::uint64_t other_camera_lost_by_pvcap = 0;
};

BehindOutcome record_with_a_stalled_worker(const std::string& name, const std::string& faults) {
  setenv("PVCAP_FAULTS", faults.c_str(), 1);
  const auto s = record(name, sim_rig_yaml({{}, {}}, 320, 240, 30, 15), 5);
  unsetenv("PVCAP_FAULTS");
  BehindOutcome o;
  EXPECT_EQ(s.result.exit_code, 0) << s.result.output;
  EXPECT_NE(s.result.output.find("PVCAP_FAULTS is set"), std::string::npos) << "an injected fault is never silent";
  const std::string warning = "lost because pvcap did not take";
  const auto first = s.result.output.find(warning);
  EXPECT_NE(first, std::string::npos) << s.result.output;
  EXPECT_EQ(s.result.output.find(warning, first + 1), std::string::npos)
      << "warned more than once: " << s.result.output;
  EXPECT_EQ(s.result.output.find("camera lost"), std::string::npos)
      << "a camera pvcap starved of buffers is not a lost camera: " << s.result.output;
  if (s.cameras.size() != 2) {
    ADD_FAILURE() << "expected 2 cameras: " << s.result.output;
    return o;
  }
  for (const auto& d : s.cameras[0].drops) o.lost_by_reason[d.reason] += d.count;
  for (const auto& d : s.cameras[1].drops)
    if (d.reason == "queue_overflow" || d.reason == "buffer_underrun") o.other_camera_lost_by_pvcap += d.count;
  o.accounting = account(s.cameras[0]);
  for (const auto& [why, n] : o.lost_by_reason)
    std::printf("%s: cam0 lost %llu frames: %s\n", name.c_str(), (unsigned long long)n, why.c_str());
  if (first != std::string::npos)
    std::printf("%s\n", s.result.output.substr(first, s.result.output.find('\n', first) - first).c_str());
  EXPECT_EQ(o.accounting.unaccounted, 0u) << "frames neither stored nor in a drop row";
  return o;
}

TEST(SimSession, FramesSentWhileTheStreamHadNoFreeBufferAreRecordedAsBufferUnderrun) {
  // The stalled worker takes no frame: they wait in the stream's buffers until every one is full,
  // and the frames the camera sends meanwhile find none (1.5 s at 30 Hz, less the 15 buffers: ~30).
  const auto o =
      record_with_a_stalled_worker("underrun", "camera_pipeline.stall_s=1.5,camera_pipeline.stall_after_s=1.5");
  EXPECT_GE(o.lost_by_reason.count("buffer_underrun") ? o.lost_by_reason.at("buffer_underrun") : 0, 20u);
  EXPECT_EQ(o.lost_by_reason.count("queue_overflow"), 0u);
  EXPECT_EQ(o.other_camera_lost_by_pvcap, 0u) << "the other camera's worker never stalled";
}

TEST(SimSession, SenselIsStoredAtFullRateWithItsDeviceAndArrivalTimes) {
  const double duration = 5;
  const auto s = record("sensel", sim_rig_yaml({{}}, kWidth, kHeight, 30, 15, "free-run", /*sensel=*/true), duration);
  ASSERT_EQ(s.result.exit_code, 0) << s.result.output;
  EXPECT_NE(s.result.output.find("sensel "), std::string::npos) << s.result.output;
  // Ground truth: every frame the emulated Morph sent (counter, true time, device µs clock).
  std::map<std::uint32_t, std::int64_t> true_ns_by_device_us;
  {
    std::ifstream in(s.dir / "sim-truth" / "sensel_frames.csv");
    std::string line;
    std::getline(in, line);
    unsigned counter = 0;
    long long t = 0;
    unsigned long dev = 0;
    while (std::getline(in, line))
      if (std::sscanf(line.c_str(), "%u,%lld,%lu", &counter, &t, &dev) == 3)
        true_ns_by_device_us[std::uint32_t(dev)] = t;
  }
  ASSERT_FALSE(true_ns_by_device_us.empty());
  pvcap::sqlite::Database db(s.dir / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
  auto q = db.prepare(
      "SELECT p.sequence, p.device_ns, p.host_ns, p.grid_cols, p.grid_rows, p.grid_xscale, p.grid_yscale, p.payload "
      "FROM pressure_frames p JOIN devices d ON d.id = p.device_id WHERE d.kind = 'sensel' ORDER BY p.host_ns");
  std::size_t n = 0, matched = 0;
  std::int64_t last_device = -1;
  std::uint64_t last_seq = 0;
  double peak_g = 0;
  while (q.step()) {
    ++n;
    const pvcap::sensel::Grid grid{int(q.column_int(3)), int(q.column_int(4)), int(q.column_int(5)),
                                   int(q.column_int(6))};
    EXPECT_EQ(grid, pvcap::sensel::kMediumDetail);
    auto f = pvcap::sensel::parse_frame(q.column_blob(7), grid);
    ASSERT_TRUE(f) << f.error().message;
    auto truth = true_ns_by_device_us.find(f.value().timestamp_us);
    ASSERT_NE(truth, true_ns_by_device_us.end()) << "a stored frame the emulator never sent";
    ++matched;
    const std::int64_t latency = q.column_int(2) - truth->second;
    EXPECT_GT(latency, -20'000'000) << "stamped long before it was made";
    EXPECT_LT(latency, 50'000'000);
    // Device time unwrapped across the emulator's 32-bit wrap (3 s into the run), strictly increasing.
    EXPECT_GT(q.column_int(1), last_device);
    last_device = q.column_int(1);
    if (n > 1) {
      EXPECT_EQ(std::uint64_t(q.column_int(0)), last_seq + 1);
    }
    last_seq = std::uint64_t(q.column_int(0));
    for (auto c : f.value().pressure->counts) peak_g = std::max(peak_g, pvcap::sensel::counts_to_grams(c));
  }
  EXPECT_NEAR(double(n), duration * 125, duration * 125 * 0.2);
  EXPECT_EQ(matched, n);
  EXPECT_NEAR(peak_g, 250.0, 25.0) << "the emulated press peaks at 250 g on its centre cell";
  EXPECT_GT(last_device, std::int64_t(4294967295LL) * 1000) << "the device clock wrapped and was unwrapped";

  // The camera shows the same fingertip at the same instants: at each video frame's true capture time
  // (its timecode), the press point is skin while the emulator presses and pad while it does not.
  auto truth = pvcap::sim::read_rig_truth(s.dir / "sim-truth");
  ASSERT_TRUE(truth) << truth.error().message;
  const auto& model = truth.value().cameras[0].model;
  const cv::Point2d p = model.project({100.0, 60.0, 0.0});  // the press point of sim_rig_yaml's Sensel
  const cv::Point px(int(std::lround(p.x)), int(std::lround(p.y)));
  auto reader = pvcap::VideoReader::open(s.dir / "cam0-000.mkv");
  ASSERT_TRUE(reader);
  cv::Mat img;
  std::int64_t pts = 0;
  int pressed = 0, lifted = 0;
  while (true) {
    auto more = reader.value()->next(img, pts);
    if (!more || !more.value()) break;
    const auto tc = pvcap::sim::read_timecode(img);
    ASSERT_TRUE(tc);
    const double force = pvcap::sim::fingertip_force(tc->true_ns, 1.0);
    const cv::Vec3b c = img.at<cv::Vec3b>(px);  // BGR
    const bool skin = c[2] > 150 && c[2] > c[0] + 40;
    if (force > 0.3) {
      ++pressed;
      EXPECT_TRUE(skin) << "pressing (force " << force << ") but no fingertip at " << px << ": " << c;
    } else if (force == 0.0) {
      ++lifted;
      EXPECT_FALSE(skin) << "lifted but a fingertip at " << px << ": " << c;
    }
  }
  EXPECT_GT(pressed, 10);
  EXPECT_GT(lifted, 10);
}

// Cameras that share a link are paced to their share of it through the feature their map has
// (Aravis' fake camera: GevSCPD, in ticks of its 1 GHz clock), the pacing stored with each; a share
// their feature cannot pace to is refused before anything is recorded, naming the feature's range.
TEST(PvcapCommand, CamerasSharingALinkArePacedToTheirShareOrRefusedByName) {
  const auto on_link = [](std::string yaml, int packet, int link_mbps) {
    const std::string from = "    packet_size: 8192\n";
    const std::string to = fmt::format("    packet_size: {}\n    link: nic0\n    link_mbps: {}\n", packet, link_mbps);
    for (auto at = yaml.find(from); at != std::string::npos; at = yaml.find(from, at + to.size()))
      yaml.replace(at, from.size(), to);
    return yaml;
  };
  // Two cameras on a 100 Gbit/s link, 1500-byte packets: each leaves 0.12 us between its packets.
  const auto paced = record("link-paced", on_link(sim_rig_yaml({{}, {}}, 320, 240, 30, 15), 1500, 100000), 2);
  ASSERT_EQ(paced.result.exit_code, 0) << paced.result.output;
  pvcap::sqlite::Database db(paced.dir / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
  for (const auto& c : paced.cameras) {
    auto q = db.prepare("SELECT json_extract(settings_json, '$.link_pacing') FROM devices WHERE id = ?");
    q.bind(1, c.device_id);
    ASSERT_TRUE(q.step());
    EXPECT_EQ(q.column_text(0).rfind("GevSCPD 120 ticks (0.12 us between its 1500-byte packets) on link 'nic0' "
                                     "(100000 Mbit/s) shared by 2 cameras",
                                     0),
              0u)
        << c.name << ": " << q.column_text(0);
  }
  // Four on a gigabit link with 8192-byte packets need 196.6 us between packets: beyond the fake
  // camera's GevSCPD (0 to 1000 ticks).
  const auto refused = record("link-refused", on_link(sim_rig_yaml({{}, {}, {}, {}}, 320, 240, 30, 15), 8192, 1000), 2);
  EXPECT_EQ(refused.result.exit_code, 1) << refused.result.output;
  EXPECT_NE(refused.result.output.find("on link 'nic0' (1000 Mbit/s) shared by 4 cameras, its 8192-byte packets need "
                                       "196.61 us between them"),
            std::string::npos)
      << refused.result.output;
  EXPECT_NE(refused.result.output.find("its range is 0 to 1000"), std::string::npos) << refused.result.output;
  EXPECT_TRUE(refused.dir.empty()) << "a session was recorded";
}

// A rate the camera cannot reach at the rig's region and format is refused by name before recording:
// the simulated SFNC 2 camera says its reachable rate (AcquisitionResultingFrameRate: its sensor reads
// 200 Mpixel/s, 217 fps at 1280 x 720).
TEST(PvcapCommand, ARateTheCameraCannotReachAtTheRigsRegionIsNamed) {
  const auto s = record("rate-out-of-reach", sim_rig_yaml({{.node_map = "sfnc2"}}, 1280, 720, 250, 15), 2);
  EXPECT_EQ(s.result.exit_code, 1) << s.result.output;
  EXPECT_NE(s.result.output.find("cam0 (serial PVSIM0 at 127.0.0.2): cannot reach 250 fps at 1280x720 BayerRG8"),
            std::string::npos)
      << s.result.output;
  EXPECT_NE(s.result.output.find("AcquisitionResultingFrameRate is 217.01 there"), std::string::npos)
      << s.result.output;
  EXPECT_TRUE(s.dir.empty()) << "a session was recorded";
}

// A light on a line the camera lacks (the simulated cameras have Line0-Line3) is refused before
// recording, at once, naming the light, the line and why.
TEST(PvcapCommand, ALightTheCameraCannotDriveIsRefusedBeforeRecording) {
  std::string yaml = sim_rig_yaml({{}}, 320, 240, 30, 15);
  yaml.replace(yaml.find("store:"), 0, "lights:\n  - {name: C, camera: cam0, line: Line7}\n");
  const auto s = record("light-refused", yaml, 2);
  EXPECT_EQ(s.result.exit_code, 1) << s.result.output;
  EXPECT_NE(s.result.output.find("light C on Line7 (steady): Line7 is not among its lines (Line0, Line1, Line2, Line3)"),
            std::string::npos)
      << s.result.output;
  EXPECT_TRUE(s.dir.empty()) << "a session was recorded";
}

TEST(PvcapCommand, BadRigFileNamesFileLineAndKeyAndRecordsNothing) {
  const fs::path work = work_dir("badrig");
  std::ofstream(work / "rig.yaml") << "name: x\ncameras:\n  - serial: A\n    framerate: 60\n";
  const auto r = run_pvcap("session --rig " + (work / "rig.yaml").string() + " --root " + (work / "s").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("rig.yaml:4: cameras[0].framerate: unknown key"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(work / "s"));
}

TEST(PvcapCommand, MissingCameraIsNamedAndLeavesNoSession) {
  const fs::path work = work_dir("nocam");
  std::ofstream(work / "rig.yaml") << "name: x\ncameras:\n  - name: top\n    address: 127.0.0.1\n";
  const auto r =
      run_pvcap("session --rig " + (work / "rig.yaml").string() + " --root " + (work / "s").string() + " --duration 1");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("top (at 127.0.0.1): no camera answers"), std::string::npos) << r.output;
  EXPECT_TRUE(!fs::exists(work / "s") || fs::is_empty(work / "s"));
}

// A live camera's node map written to a file (`devices --dump-node-map`), then judged offline by
// `camera check`: the simulated camera's own map, with its timestamp latch, is usable on the latch
// clock; a camera that is not there is named with those that are.
TEST(PvcapCommand, ACamerasNodeMapIsDumpedAndChecked) {
  const fs::path work = work_dir("dump-node-map");
  std::ofstream(work / "rig.yaml") << sim_rig_yaml({{}, {}}, 320, 240, 10, 15, "free-run", /*sensel=*/false);
  auto r = run_pvcap(fmt::format("devices --sim {} --dump-node-map PVSIM1 --out {}", (work / "rig.yaml").string(),
                                 (work / "cam1.xml").string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("camera PVSIM1's node map"), std::string::npos) << r.output;
  ASSERT_TRUE(fs::exists(work / "cam1.xml"));
  r = run_pvcap(fmt::format("camera check --json --pixel-format BayerRG8 --node-map {}", (work / "cam1.xml").string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output.substr(r.output.find('{')));
  EXPECT_EQ(j["clock"], "latch") << r.output;
  r = run_pvcap(fmt::format("devices --sim {} --dump-node-map NOSUCH --out {}", (work / "rig.yaml").string(),
                            (work / "x.xml").string()));
  EXPECT_EQ(r.exit_code, 2) << r.output;  // a user's mistake, as a missing rig file
  EXPECT_NE(r.output.find("no camera NOSUCH answered discovery (those that did: PVSIM"), std::string::npos) << r.output;
}

TEST(PvcapCommand, DevicesListsTheSimulatedCamerasAndSensel) {
  const fs::path work = work_dir("devices");
  std::ofstream(work / "rig.yaml") << sim_rig_yaml({{}, {}, {}, {}}, 320, 240, 10, 15, "free-run", /*sensel=*/true);
  const auto r = run_pvcap("devices --sim " + (work / "rig.yaml").string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("SM01164910368"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("firmware 0.16.78, grid 47x27"), std::string::npos) << r.output;
  for (int i = 0; i < 4; ++i) {
    EXPECT_NE(r.output.find("PVSIM" + std::to_string(i)), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("127.0.0." + std::to_string(i + 2)), std::string::npos) << r.output;
  }
}
