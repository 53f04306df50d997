// The timeline end to end on the simulated rig: `pvcap eval-sync` records four 60 Hz
// cameras with drifting, offset clocks and a Sensel whose USB delay has a long tail,
// that loses frames and resets its clock; the store is then checked against the
// simulator's truth. The accuracy bounds here leave room for ctest's load on 2 cores;
// the targets are eval-sync's own (docs/performance-log.md).
#include <gtest/gtest.h>
#include <unistd.h>

#include <fmt/format.h>
#include <cmath>
#include <cstdio>

#include <fstream>
#include <set>
#include <sstream>

#include "sim/sync_evaluation.h"
#include "storage/index/database.h"
#include "storage/index/session_reader.h"
#include "tests/integration/session_under_test.h"

using namespace pvcap;

namespace {
std::filesystem::path newest_session(const std::filesystem::path& root) {
  std::filesystem::path dir;
  for (const auto& e : std::filesystem::directory_iterator(root))
    if (e.is_directory() && e.path().filename().string()[0] != '.') dir = e.path();
  return dir;
}
std::int64_t scalar(sqlite::Database& db, const std::string& sql) {
  auto q = db.prepare(sql);
  EXPECT_TRUE(q.step()) << sql;
  return q.column_int(0);
}
}  // namespace

TEST(TimelineSession, SamplesReferenceEveryCameraAndThePressureAroundThemOnOneClock) {
  const auto root = std::filesystem::temp_directory_path() / fmt::format("pvcap-timeline-{}", getpid());
  std::filesystem::remove_all(root);
  const auto run = pvcap::testing::run_pvcap(fmt::format("eval-sync --seconds 14 --root {}", root.string()));
  ASSERT_TRUE(run.exit_code == 0 || run.exit_code == 1) << run.output;  // 1: a target missed, still evaluated
  ASSERT_NE(run.output.find("paired with the truly nearest pressure frame"), std::string::npos) << run.output;
  const auto dir = newest_session(root / "sessions");
  ASSERT_FALSE(dir.empty()) << run.output;
  sqlite::Database db(dir / "session.db", sqlite::Database::Mode::ReadOnly);

  // ~15 samples per second, each with a frame of (nearly) every camera, on a grid that does not drift.
  const auto samples = scalar(db, "SELECT count(*) FROM samples");
  EXPECT_GE(samples, 14 * 15 - 3);
  EXPECT_LE(samples, 14 * 15 + 3);
  // Most groups complete. The simulated cameras expose when their threads run, on the same 2 cores as
  // the recorder, so ctest's load moves their exposures and splits some groups (the grouping rule
  // itself is checked exactly by the Grouper's unit tests).
  EXPECT_GE(scalar(db, "SELECT count(*) FROM samples WHERE cameras = 4") * 3, samples * 2) << "most groups complete";
  EXPECT_EQ(scalar(db, "SELECT count(*) FROM samples s1 JOIN samples s2 ON s2.id = s1.id + 1 WHERE s2.tick <= s1.tick"),
            0);
  EXPECT_EQ(scalar(db,
                   "SELECT count(*) FROM samples WHERE abs(tick_ns - (SELECT started_host_ns FROM session) - "
                   "tick * (1e9 / 15)) > 1"),
            0)
      << "tick k lies at k/15 s after the session start, exactly";
  // Every group spans at most half a frame period (60 Hz: 8.33 ms) on the final clock models: the
  // live grouper held it on the models of the moment, and the re-mapping takes out a frame the final
  // models put farther (a group formed on a poor fit at a loaded start; CI once saw 22 ms).
  const auto left = scalar(db, "SELECT count(*) FROM frames WHERE reason = 'outside_its_group'");
  std::printf(
      "group span on the final clock models: max %.3f ms (rule 8.333 ms); %lld camera frames left their "
      "group at the re-mapping\n",
      double(scalar(db, "SELECT max(span_ns) FROM samples")) / 1e6, static_cast<long long>(left));
  EXPECT_EQ(scalar(db, "SELECT count(*) FROM samples WHERE span_ns > 8333333"), 0)
      << "a group wider than half a frame period on the final clock models";

  // The video holds exactly the samples' frames: kept <=> referenced by a sample, but for a frame the
  // re-mapping took out of its group (named so, still in its video).
  EXPECT_EQ(scalar(db,
                   "SELECT count(*) FROM frames f WHERE kept = 1 AND NOT EXISTS (SELECT 1 FROM sample_frames sf "
                   "WHERE sf.device_id = f.device_id AND sf.connection = f.connection AND sf.sequence = f.sequence) "
                   "AND reason IS NOT 'outside_its_group'"),
            0);
  EXPECT_EQ(scalar(db,
                   "SELECT count(*) FROM frames f WHERE reason = 'outside_its_group' AND (kept = 0 OR EXISTS (SELECT 1 "
                   "FROM sample_frames sf WHERE sf.device_id = f.device_id AND sf.connection = f.connection AND "
                   "sf.sequence = f.sequence))"),
            0);
  EXPECT_EQ(scalar(db,
                   "SELECT count(*) FROM sample_frames sf JOIN frames f USING (device_id, connection, sequence) "
                   "WHERE f.kept = 0 AND f.reason <> 'encoder_behind'"),
            0);
  // Every other good frame says why it is not in the video.
  EXPECT_EQ(
      scalar(db, "SELECT count(*) FROM frames WHERE status = 'good' AND kept = 0 AND (reason IS NULL OR reason = '')"),
      0);

  // Pressure: nearest plus both neighbours with their offsets, consistent with the mapped times. A
  // sample goes without pressure only when no stored frame lies within the pairing's limit (20 ms):
  // the polled Sensel scans when asked, so a starved reader thread leaves real gaps in its stream.
  EXPECT_EQ(scalar(db,
                   "SELECT count(*) FROM samples s WHERE s.pressure_sequence IS NULL AND EXISTS (SELECT 1 FROM "
                   "pressure_frames p WHERE abs(p.mapped_ns - s.t_ns) <= 20000000)"),
            0)
      << "a sample left without pressure although a frame was near enough";
  EXPECT_GE(scalar(db, "SELECT count(*) FROM samples WHERE pressure_sequence IS NOT NULL") * 100, samples * 90);
  EXPECT_EQ(scalar(db,
                   "SELECT count(*) FROM samples WHERE pressure_sequence IS NOT NULL AND (before_offset_ns > 0 OR "
                   "after_offset_ns <= 0 OR pressure_offset_ns NOT IN (before_offset_ns, after_offset_ns) OR "
                   "abs(pressure_offset_ns) > min(-before_offset_ns, after_offset_ns))"),
            0)
      << "the nearest frame is the nearer of the two around the sample";
  EXPECT_EQ(scalar(db,
                   "SELECT count(*) FROM samples WHERE pressure_sequence IS NOT NULL AND after_offset_ns - "
                   "before_offset_ns <= 16200000 AND abs(pressure_offset_ns) > 8100000"),
            0)
      << "at ~125 Hz the nearest frame is at most half a period away where the stream has no gap";
  EXPECT_EQ(scalar(db,
                   "SELECT count(*) FROM samples s JOIN pressure_frames p ON p.device_id = s.pressure_device_id "
                   "AND p.sequence = s.pressure_sequence WHERE p.mapped_ns - s.t_ns <> s.pressure_offset_ns"),
            0);
  // The device lost ~1 % of its frames: counted by its counter, as drops.
  EXPECT_GT(scalar(db,
                   "SELECT coalesce(sum(count), 0) FROM drops d JOIN devices v ON v.id = d.device_id WHERE "
                   "v.kind = 'sensel'"),
            0);
  // Its clock reset half-way: one new segment, seen in the counts and the stored models.
  EXPECT_EQ(scalar(db, "SELECT count FROM timeline_counts WHERE what = 'clock_resets: sensel'"), 1);
  EXPECT_EQ(scalar(db,
                   "SELECT max(segment) FROM clock_models m JOIN devices v ON v.id = m.device_id WHERE "
                   "v.kind = 'sensel'"),
            1);

  // The cameras' clocks are read through their timestamp latch; the Sensel has none.
  EXPECT_EQ(scalar(db,
                   "SELECT count(DISTINCT m.device_id) FROM clock_models m JOIN devices v ON v.id = m.device_id "
                   "WHERE v.kind = 'camera' AND m.source = 'latch'"),
            4);
  // Under either naming family's latch (cam1 and cam3 serve SFNC 2 names, sim/sync_evaluation.cpp),
  // and each SFNC 2 camera's rate took only through its enable (without it the engine's own 25 fps
  // would read back and the camera be refused).
  for (int i = 0; i < 4; ++i) {
    auto q = db.prepare(
        fmt::format("SELECT json_extract(settings_json, '$.features.timestamp_latch'), "
                    "coalesce(json_extract(settings_json, '$.features.frame_rate_enable'), ''), "
                    "json_extract(settings_json, '$.features.exposure_time'), "
                    "json_extract(settings_json, '$.stamp_to_mid_exposure_ns'), "
                    "json_extract(settings_json, '$.exposure_us'), json_extract(settings_json, '$.gain_unit') "
                    "FROM devices WHERE name = 'cam{}'",
                    i));
    ASSERT_TRUE(q.step()) << i;
    EXPECT_EQ(q.column_text(0), i % 2 ? "TimestampLatch" : "TimestampControlLatch") << i;
    EXPECT_EQ(q.column_text(1), i % 2 ? "AcquisitionFrameRateEnable" : "") << i;
    // cam2's exposure is ExposureTimeRaw, 125 steps of 20 us: stored and used as 2500 us, never as 125.
    EXPECT_EQ(q.column_text(2), i % 2 ? "ExposureTime" : i == 2 ? "ExposureTimeRaw" : "ExposureTimeAbs") << i;
    // Its stamps mark the exposure's start; the image's instant is half its exposure later.
    const int exposures_us[] = {6000, 4000, 2500, 1000};
    EXPECT_EQ(q.column_int(3), exposures_us[i] * 500) << i;
    EXPECT_DOUBLE_EQ(q.column_double(4), exposures_us[i]) << i;
    // Aravis' fake camera has only its own gain counts (GainRaw): the stored gain says so.
    EXPECT_EQ(q.column_text(5), i % 2 ? "dB" : "GainRaw counts") << i;
    // The SFNC 2 cameras say their temperature (DeviceTemperature, warming 0.5 C a second): read every
    // second, an event at the first reading and at each degree; the others have none to say.
    auto states = db.prepare(fmt::format(
        "SELECT count(*), coalesce(min(message), '') FROM events WHERE kind = 'camera_state' AND device_id = "
        "(SELECT id FROM devices WHERE name = 'cam{}') AND message LIKE '%device temperature%'",
        i));
    ASSERT_TRUE(states.step());
    if (i % 2) {
      EXPECT_GE(states.column_int(0), 4) << i;
      EXPECT_NE(states.column_text(1).find("(DeviceTemperature)"), std::string::npos) << states.column_text(1);
    } else {
      EXPECT_EQ(states.column_int(0), 0) << i;
    }
  }
  // Each frame's own state, from its chunk data: the SFNC 2 cameras offer it (their frames come with
  // a leader of payload type 0x4001 and the chunks after the image, sim/gvsp_sender.h), and every good
  // frame's row holds its counter (the frame's id), its timestamp (the leader's), the exposure the
  // camera read back and its gain; the others send none, and their rows hold none.
  for (int i = 0; i < 4; ++i) {
    const std::string cam = fmt::format("(SELECT id FROM devices WHERE name = 'cam{}')", i);
    const std::int64_t good = scalar(db, "SELECT count(*) FROM frames WHERE status = 'good' AND device_id = " + cam);
    const std::int64_t with_chunks =
        scalar(db,
               "SELECT count(*) FROM frames WHERE status = 'good' AND chunk_frame_counter IS NOT NULL AND "
               "device_id = " +
                   cam);
    EXPECT_GT(good, 100) << i;
    if (i % 2 == 0) {
      EXPECT_EQ(with_chunks, 0) << i;
      continue;
    }
    EXPECT_EQ(with_chunks, good) << "cam" << i << ": every good frame carries its chunks";
    const int exposures_us[] = {6000, 4000, 2500, 1000};
    const double wobble_us = i == 3 ? pvcap::sim::kCam3ExposureWobbleUs : 0.0;
    EXPECT_EQ(
        scalar(db, fmt::format(
                       "SELECT count(*) FROM frames WHERE status = 'good' AND device_id = {0} AND "
                       "(chunk_frame_counter % 65536 <> frame_id % 65536 OR chunk_timestamp <> "
                       "device_ns OR (abs(chunk_exposure_us - {1}) > 0.5 AND abs(abs(chunk_exposure_us - {1}) - {2}) > "
                       "0.5) OR chunk_gain IS NULL)",
                       cam, exposures_us[i], wobble_us)),
        0)
        << "cam" << i << ": a frame's chunks disagree with its leader or the camera's exposure";
    // cam3's exposure moved frame by frame (after its first, at the one set), both ways; its timing (below, against the
    // truth) holds only because each frame's instant follows its own exposure.
    if (wobble_us > 0) {
      EXPECT_EQ(scalar(db, fmt::format("SELECT count(DISTINCT round(chunk_exposure_us)) FROM frames WHERE status = "
                                       "'good' AND device_id = {} AND abs(chunk_exposure_us - {}) > 0.5",
                                       cam, exposures_us[i])),
                2);
    }
    EXPECT_EQ(scalar(db, fmt::format("SELECT json_extract(settings_json, '$.chunks.chunk_exposure_time') = "
                                     "'ChunkExposureTime' FROM devices WHERE id = {}",
                                     cam)),
              1);
  }
  // ...and the reader hands them out with each frame.
  {
    auto reader = pvcap::SessionReader::open(dir);
    ASSERT_TRUE(reader) << reader.error().message;
    for (const auto& c : reader.value()->cameras()) {
      auto timing = reader.value()->frame_timing(c.device_id);
      ASSERT_TRUE(timing) << timing.error().message;
      std::size_t with = 0;
      for (const auto& t : timing.value())
        if (t.good && t.chunk_exposure_us && t.chunk_timestamp == t.device_ns) ++with;
      if (c.name == "cam1" || c.name == "cam3")
        EXPECT_GT(with, 100u) << c.name;
      else
        EXPECT_EQ(with, 0u) << c.name;
    }
  }

  // From each camera's first frame on: a probe taken as its acquisition starts maps the first frames
  // (by their arrivals they were 4-14 ms late on an idle machine, 20-110 ms at a loaded 1080p start,
  // and a sample chosen on that clock took a group its tick's neighbour should have had).
  EXPECT_EQ(scalar(db,
                   "SELECT count(*) FROM clock_models m JOIN devices v ON v.id = m.device_id WHERE v.kind = "
                   "'camera' AND m.source = 'latch' AND m.host_ns = (SELECT min(host_ns) FROM clock_models WHERE "
                   "device_id = m.device_id)"),
            4);
  EXPECT_EQ(scalar(db,
                   "SELECT count(*) FROM clock_models m JOIN devices v ON v.id = m.device_id WHERE "
                   "v.kind = 'sensel' AND m.source <> 'arrivals'"),
            0);

  // Against the truth: every stream on one clock; pairing far better than arrival times.
  const auto e = pvcap::sim::evaluate_sync(dir, 3);
  std::printf("%s\n", pvcap::sim::format_evaluation(e).c_str());
  ASSERT_EQ(e.streams.size(), 5u);
  for (const auto& s : e.streams) {
    EXPECT_GT(s.frames, 100u) << s.name;
    if (s.is_camera) {
      // Mapped by timestamp-latch probes: the target, 0.1 ms p99 (measured 0.001-0.027 ms, alone
      // and beside two CPU hogs, 2026-11-26). Against the image's instant, the middle of its
      // exposure: the stamps mark its start, 0.5-3 ms earlier, which the bias would show.
      EXPECT_LT(std::fabs(s.bias_ms), 0.1) << s.name;
      EXPECT_LT(s.p99_ms, 0.1) << s.name;
      EXPECT_LT(s.p99_ms, s.arrival_p99_ms / 4) << s.name << ": mapping must beat the raw arrival stamp";
    } else {
      // No latch: mapped through the lower envelope of arrivals, which a starved reader thread
      // pushes up. The target, 0.5 ms p99 (measured 0.03-0.11 ms, alone and beside two CPU hogs).
      EXPECT_LT(std::fabs(s.bias_ms), 0.5) << s.name;
      EXPECT_LT(s.p99_ms, 0.5) << s.name;
      EXPECT_LT(s.p99_ms, s.arrival_p99_ms / 4) << s.name << ": mapping must beat the raw arrival stamp";
    }
  }
  // Paired right for 99.5 % of the samples, eval-sync's target; of a 14 s run's ~180 that leaves
  // none, so one sample is allowed (beside two CPU hogs one went unpaired: 99.47 %). Right includes
  // a pick truly farther than the nearest by no more than the measured errors of its times (the
  // Sensel's unseen constant latency, 0.06-0.11 ms, decides near-midpoint samples: CI once saw 21 of
  // 172); such a pick is never farther than the Sensel's timing target.
  const auto right = e.right();
  EXPECT_GE(right * 1000 + 1000, e.samples * 995) << pvcap::sim::format_evaluation(e);
  EXPECT_LT(e.within_error_max_ms, 0.5) << pvcap::sim::format_evaluation(e);
  EXPECT_GT(e.paired_nearest, e.naive_nearest + e.samples / 4) << pvcap::sim::format_evaluation(e);

  // `--evaluate` measures the kept session again: the same figures, the same verdict; a folder
  // without the simulator's truth is named.
  const auto again = pvcap::testing::run_pvcap(fmt::format("eval-sync --evaluate {}", dir.string()));
  EXPECT_EQ(again.exit_code, e.missed.empty() ? 0 : 1) << again.output;
  EXPECT_NE(again.output.find(pvcap::sim::format_evaluation(e)), std::string::npos) << again.output;
  const auto foreign = pvcap::testing::run_pvcap(fmt::format("eval-sync --evaluate {}", root.string()));
  EXPECT_NE(foreign.exit_code, 0);
  EXPECT_NE(foreign.output.find(root.string() + ": not a session recorded on the simulated rig"), std::string::npos)
      << foreign.output;
  std::filesystem::remove_all(root);
}
