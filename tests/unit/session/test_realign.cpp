// The end-of-session re-mapping from the fits the store holds: each clock segment applied from its
// first row on, samples re-paired with the nearest pressure frame, committed in steps, and an
// interrupted run finished by running it again.
#include <gtest/gtest.h>

#include <filesystem>
#include <stdexcept>

#include <fmt/format.h>
#include <unistd.h>

#include "session/realign.h"
#include "storage/index/session_index.h"

namespace fs = std::filesystem;
using namespace pvcap;

namespace {

constexpr std::int64_t kMillisecond = 1'000'000;

// A camera at 30 Hz whose clock restarts at frame 30 (a reconnect: its device time starts again
// near zero), a Sensel at 125 Hz, and a sample every other camera frame. Every mapped time is
// recorded wrong (+7 ms) as an online fit might have had it; the stored fits are exact:
// camera host = device + 1000 ms (segment 0) or device + 2000 ms (segment 1), Sensel host = device
// + 500 ms - 0.5 ms latency.
struct Fixture {
  fs::path dir;
  std::int64_t camera = 0, sensel = 0;
  std::size_t samples = 0;

  explicit Fixture(const std::string& name) {
    dir = fs::temp_directory_path() / fmt::format("pvcap-realign-{}-{}", name, getpid());
    fs::remove_all(dir);
    fs::create_directories(dir);
    SessionIndex index = SessionIndex::create(dir / "session.db");
    index.add_session({1, 0, "test", "rig", "rig.yaml", "", true});
    camera = index.add_device({"camera", "cam0", "", "", "", "", "", ""});
    sensel = index.add_device({"sensel", "sensel", "", "", "", "", "", ""});
    auto camera_host = [](int i) { return std::int64_t(i) * 33'333'333 + 10 * kMillisecond; };
    auto camera_device = [&](int i) {
      return i < 30 ? camera_host(i) - 1000 * kMillisecond : camera_host(i) - 2000 * kMillisecond;
    };
    for (int i = 0; i < 60; ++i) {
      FrameRecord f{camera,
                    0,
                    std::uint64_t(i + 1),
                    std::uint64_t(i + 1),
                    camera_device(i),
                    camera_host(i) + 3 * kMillisecond,
                    0,
                    "good",
                    true,
                    "",
                    {},
                    {},
                    camera_host(i) + 7 * kMillisecond,
                    {}};
      index.add_frame(f);
    }
    for (int k = 0; k < 250; ++k) {
      const std::int64_t host = std::int64_t(k) * 8 * kMillisecond;
      PressureRecord p{sensel,
                       0,
                       std::uint64_t(k),
                       0,
                       host - 500 * kMillisecond + kMillisecond / 2,
                       host + kMillisecond,
                       0,
                       185,
                       105,
                       1,
                       1,
                       {1, 2, 3},
                       host + 7 * kMillisecond,
                       0,
                       {}};
      index.add_pressure(p);
    }
    for (int i = 0; i + 1 < 60; i += 2) {
      SampleRecord s{samples,
                     i / 2,
                     camera_host(i),
                     camera_host(i) + 7 * kMillisecond,
                     0,
                     {{camera, 0, std::uint64_t(i + 1), 0}},
                     std::nullopt,
                     std::nullopt,
                     std::nullopt};
      index.add_sample(s);
      ++samples;
    }
    // What the timeline stores: a row a second, the reset's rows, and each segment's final fit.
    auto row = [&](std::int64_t device, std::int64_t host, int segment, std::int64_t x0, double offset,
                   std::int64_t latency) {
      index.add_clock_model({device, host, segment, x0, offset, 0.0, latency, "arrivals", 10, 4, 0, 0});
    };
    row(camera, camera_host(0), 0, 0, 990 * kMillisecond, 0);  // an early, still imprecise fit
    row(camera, camera_host(29), 0, 0, 1000 * kMillisecond, 0);
    row(camera, camera_host(30), 1, 0, 1990 * kMillisecond, 0);
    row(camera, camera_host(59), 1, 0, 2000 * kMillisecond, 0);
    row(sensel, 0, 0, 0, 500 * kMillisecond, kMillisecond / 2);
  }
  ~Fixture() { fs::remove_all(dir); }
};

struct SampleRow {
  std::int64_t t_ns = 0, pressure_sequence = -1, pressure_offset_ns = 0;
};

std::vector<SampleRow> sample_rows(sqlite::Database& db) {
  std::vector<SampleRow> out;
  auto q = db.prepare("SELECT t_ns, pressure_sequence, pressure_offset_ns FROM samples ORDER BY id");
  while (q.step()) out.push_back({q.column_int(0), q.column_null(1) ? -1 : q.column_int(1), q.column_int(2)});
  return out;
}

}  // namespace

TEST(Realign, EachSegmentIsMappedWithItsLastStoredFitAndEverySampleRePaired) {
  Fixture f("mapped");
  SessionIndex index = SessionIndex::open_for_update(f.dir / "session.db");
  std::vector<std::string> said;
  const auto r = realign(index, {20 * kMillisecond, 4, [&](const std::string& s) { said.push_back(s); }});
  EXPECT_EQ(r.samples, f.samples);
  EXPECT_EQ(r.segments, 3u);
  EXPECT_FALSE(realign_pending(index));
  // Camera frames on both sides of the restart land on their true host time.
  auto q = index.db().prepare("SELECT sequence, mapped_ns, device_ns FROM frames ORDER BY sequence");
  while (q.step()) {
    const auto seq = q.column_int(0);
    const std::int64_t offset = seq <= 30 ? 1000 * kMillisecond : 2000 * kMillisecond;
    EXPECT_EQ(q.column_int(1), q.column_int(2) + offset) << "frame " << seq;
  }
  // Pressure: device + 500 ms - 0.5 ms latency, so every sample's nearest frame is within 4 ms.
  for (const auto& s : sample_rows(index.db())) {
    ASSERT_GE(s.pressure_sequence, 0);
    EXPECT_LE(std::abs(s.pressure_offset_ns), 4 * kMillisecond);
    auto p = index.db().prepare("SELECT mapped_ns FROM pressure_frames WHERE sequence = ?");
    p.bind_all(s.pressure_sequence);
    ASSERT_TRUE(p.step());
    EXPECT_EQ(p.column_int(0) - s.t_ns, s.pressure_offset_ns);
  }
  // Progress: the frames' step, then one line per step of 4 samples but the last.
  ASSERT_FALSE(said.empty());
  EXPECT_NE(said.front().find("3 clock segments"), std::string::npos) << said.front();
  EXPECT_EQ(said.size(), 1 + (f.samples + 3) / 4 - 1);
}

TEST(Realign, AnInterruptedReMappingIsPendingAndRunningItAgainFinishesIt) {
  Fixture f("interrupted");
  std::vector<SampleRow> reference;
  {
    Fixture g("reference");  // the same session, re-mapped without interruption
    SessionIndex index = SessionIndex::open_for_update(g.dir / "session.db");
    realign(index, {20 * kMillisecond, 4, nullptr});
    reference = sample_rows(index.db());
  }
  {
    SessionIndex index = SessionIndex::open_for_update(f.dir / "session.db");
    int steps = 0;
    // Killed after two committed steps of samples (the throw stands for the process dying).
    EXPECT_THROW(realign(index, {20 * kMillisecond, 4,
                                 [&](const std::string&) {
                                   if (++steps == 3) throw std::runtime_error("killed");
                                 }}),
                 std::runtime_error);
    EXPECT_TRUE(realign_pending(index));
    const auto partial = sample_rows(index.db());
    std::size_t done = 0;
    for (std::size_t i = 0; i < partial.size(); ++i) done += partial[i].t_ns == reference[i].t_ns;
    EXPECT_EQ(done, 8u) << "two steps of four samples were committed";
  }
  auto again = realign_if_needed(f.dir, /*interrupted=*/false, nullptr);
  ASSERT_TRUE(again) << again.error().message;
  ASSERT_TRUE(again.value().has_value()) << "a pending re-mapping is run again";
  SessionIndex index = SessionIndex::open_for_update(f.dir / "session.db");
  EXPECT_FALSE(realign_pending(index));
  const auto finished = sample_rows(index.db());
  ASSERT_EQ(finished.size(), reference.size());
  for (std::size_t i = 0; i < finished.size(); ++i) {
    EXPECT_EQ(finished[i].t_ns, reference[i].t_ns) << i;
    EXPECT_EQ(finished[i].pressure_sequence, reference[i].pressure_sequence) << i;
  }
  auto nothing = realign_if_needed(f.dir, false, nullptr);
  ASSERT_TRUE(nothing);
  EXPECT_FALSE(nothing.value().has_value()) << "a finished re-mapping is not run again";
}

// A kill can commit a sample before the rows of the frames it names (they were still being
// encoded): those frames are lost at the interruption. The sample keeps its live instant, and its
// pressure is re-paired against the re-mapped pressure frames, so its offset stays consistent.
TEST(Realign, ASampleWhoseFramesWereNeverStoredKeepsItsInstantAndIsRePaired) {
  Fixture f("lost");
  const std::int64_t t = 59 * 33'333'333 + 10 * kMillisecond + 5 * kMillisecond;  // within the pressure stream's span
  {
    SessionIndex index = SessionIndex::open_for_update(f.dir / "session.db");
    SampleRecord s{f.samples, 30, t, t, 0, {{f.camera, 0, 61, 0}}, std::nullopt, std::nullopt, std::nullopt};
    index.add_sample(s);
  }
  SessionIndex index = SessionIndex::open_for_update(f.dir / "session.db");
  const auto r = realign(index, {20 * kMillisecond, 4, nullptr});
  EXPECT_EQ(r.samples, f.samples + 1);
  const auto rows = sample_rows(index.db());
  ASSERT_EQ(rows.size(), f.samples + 1);
  const auto& lost = rows.back();
  EXPECT_EQ(lost.t_ns, t);
  ASSERT_GE(lost.pressure_sequence, 0);
  auto p = index.db().prepare("SELECT mapped_ns FROM pressure_frames WHERE sequence = ?");
  p.bind_all(lost.pressure_sequence);
  ASSERT_TRUE(p.step());
  EXPECT_EQ(p.column_int(0) - t, lost.pressure_offset_ns);
  EXPECT_LE(std::abs(lost.pressure_offset_ns), 4 * kMillisecond);
}

// A group formed on a poor early fit (a loaded start): cam1's frame one period later than the
// others' instant was grouped with them. The final fits show it 16.7 ms away, twice the rule's
// 8.3 ms, and the re-mapping takes it out: the group keeps the most frames within the rule (the
// two that agree, though the odd one is nearer the tick), or, one against one, the frame nearer the
// tick. What left stays in its video, named; a second run changes nothing.
TEST(Realign, AGroupTheFinalFitsWidenLosesTheFramesOutsideTheRuleAndKeepsThemNamedInTheVideo) {
  const fs::path dir = fs::temp_directory_path() / fmt::format("pvcap-realign-regroup-{}", getpid());
  fs::remove_all(dir);
  fs::create_directories(dir);
  constexpr std::int64_t kPeriod = 16'666'667, kLimit = 8'333'333;
  auto host = [](int i) { return 100 * kMillisecond + std::int64_t(i) * kPeriod; };
  std::vector<std::int64_t> cams;
  {
    SessionIndex index = SessionIndex::create(dir / "session.db");
    index.add_session({1, 0, "test", "rig", "rig.yaml", "", true});
    for (int c = 0; c < 3; ++c) {
      cams.push_back(index.add_device({"camera", fmt::format("cam{}", c), "", "", "", "", "", ""}));
      for (int i = 0; i < 8; ++i) {
        // Device clock = host - (c + 1) s; the stored mapped time is what the early fit said.
        FrameRecord f{cams[c],
                      0,
                      std::uint64_t(i + 1),
                      std::uint64_t(i + 1),
                      host(i) - (c + 1) * 1000 * kMillisecond,
                      host(i) + kMillisecond,
                      0,
                      "good",
                      true,
                      "",
                      {},
                      {},
                      host(i),
                      {}};
        index.add_frame(f);
      }
      index.add_clock_model(
          {cams[c], host(0), 0, 0, double((c + 1) * 1000 * kMillisecond), 0.0, 0, "arrivals", 10, 4, 0, 0});
    }
    // Sample 0: cam0 and cam2 at frame 1, cam1 at frame 2; its tick nearer cam1's frame.
    index.add_sample({0,
                      0,
                      host(1) + 14 * kMillisecond,
                      host(1),
                      0,
                      {{cams[0], 0, 2, 0}, {cams[1], 0, 3, 0}, {cams[2], 0, 2, 0}},
                      std::nullopt,
                      std::nullopt,
                      std::nullopt});
    // Sample 1: cam0 at frame 5, cam1 at frame 6; one against one, its tick nearer cam0's frame.
    index.add_sample({1,
                      1,
                      host(5) + 2 * kMillisecond,
                      host(5),
                      0,
                      {{cams[0], 0, 6, 0}, {cams[1], 0, 7, 0}},
                      std::nullopt,
                      std::nullopt,
                      std::nullopt});
  }
  auto table = [&](sqlite::Database& db) {
    std::string out;
    for (const char* sql : {"SELECT id, t_ns, span_ns, cameras FROM samples ORDER BY id",
                            "SELECT sample_id, device_id, sequence, offset_ns FROM sample_frames ORDER BY 1, 2",
                            "SELECT device_id, sequence, kept, coalesce(reason, '') FROM frames ORDER BY 1, 2"}) {
      auto q = db.prepare(sql);
      while (q.step())
        out += fmt::format("{} {} {} {}\n", q.column_text(0), q.column_text(1), q.column_text(2), q.column_text(3));
    }
    return out;
  };
  std::string first;
  {
    SessionIndex index = SessionIndex::open_for_update(dir / "session.db");
    const auto r = realign(index, {20 * kMillisecond, 2000, nullptr, kLimit});
    EXPECT_EQ(r.frames_out_of_groups, 2u);
    ASSERT_EQ(r.left_by_camera.size(), 1u) << "only cam1 lost frames";
    EXPECT_EQ(r.left_by_camera[0].camera, "cam1");
    EXPECT_EQ(r.left_by_camera[0].left, 2u);
    EXPECT_EQ(r.left_by_camera[0].in_samples, 2u);
    EXPECT_EQ(r.cameras_that_left(0.02), "cam1 (2 of its 2 sampled frames)") << "named for the session's warning";
    EXPECT_NE(r.many_left_warning().find("frames of cam1 (2 of its 2 sampled frames) more than 8.33 ms"),
              std::string::npos)
        << r.many_left_warning();
    auto q = index.db().prepare("SELECT id, t_ns, span_ns, cameras FROM samples ORDER BY id");
    ASSERT_TRUE(q.step());
    EXPECT_EQ(q.column_int(1), host(1)) << "cam0 and cam2 agree";
    EXPECT_EQ(q.column_int(2), 0);
    EXPECT_EQ(q.column_int(3), 2);
    ASSERT_TRUE(q.step());
    EXPECT_EQ(q.column_int(1), host(5)) << "cam0's frame was nearer the tick";
    EXPECT_EQ(q.column_int(3), 1);
    auto left = index.db().prepare(
        "SELECT device_id, sequence, kept FROM frames WHERE reason = 'outside_its_group' ORDER BY sequence");
    ASSERT_TRUE(left.step());
    EXPECT_EQ(left.column_int(0), cams[1]);
    EXPECT_EQ(left.column_int(1), 3);
    EXPECT_EQ(left.column_int(2), 1) << "still in its video";
    ASSERT_TRUE(left.step());
    EXPECT_EQ(left.column_int(0), cams[1]);
    EXPECT_EQ(left.column_int(1), 7);
    EXPECT_FALSE(left.step());
    auto in_samples = index.db().prepare("SELECT count(*) FROM sample_frames WHERE device_id = ?");
    in_samples.bind_all(cams[1]);
    ASSERT_TRUE(in_samples.step());
    EXPECT_EQ(in_samples.column_int(0), 0) << "cam1's two frames left their samples";
    auto done = index.db().prepare("SELECT message FROM events WHERE kind = 'realign_done'");
    ASSERT_TRUE(done.step());
    EXPECT_NE(done.column_text(0).find("2 camera frames left groups the final fits put wider than 8.33 ms (reason "
                                       "outside_its_group: cam1 2 of 2)"),
              std::string::npos)
        << done.column_text(0);
    first = table(index.db());
  }
  {
    SessionIndex index = SessionIndex::open_for_update(dir / "session.db");
    const auto r = realign(index, {20 * kMillisecond, 2000, nullptr, kLimit});
    EXPECT_EQ(r.frames_out_of_groups, 0u);
    EXPECT_TRUE(r.cameras_that_left(0.0).empty());
    EXPECT_TRUE(r.many_left_warning().empty());
    EXPECT_EQ(table(index.db()), first) << "the same fits give the same groups";
  }
  fs::remove_all(dir);
}
