// A power cut at any moment of a protocol session: the session's writes, syncs and name changes are
// traced (tests/power_cut/io_trace.c) while it runs as on the rig; then, at cut points drawn at
// random (the seed is printed: PVCAP_POWER_CUT_SEED repeats a run), the session folder is built as
// the cut would have left it (tests/power_cut/crash_image.h) and must recover, verify and read,
// having lost at most the durability horizon docs/store.md states, and keeping every protocol
// event acknowledged more than a second before the cut.
// PVCAP_POWER_CUT_POINTS sets how many cut points (bench/power_cut.sh runs many more).
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <tuple>

#include <fmt/format.h>

#include "storage/session_reader.h"
#include "storage/sqlite/database.h"
#include "tests/integration/session_under_test.h"
#include "tests/power_cut/crash_image.h"
#include "tests/power_cut/trace_format.h"

namespace fs = std::filesystem;
using namespace pvcap::testing;

namespace {

// What docs/store.md promises a power cut loses, with the default store.sync_interval_s of 1 s: the
// last second of video plus the open half-second cluster; the index's last 250 ms of rows.
constexpr double kVideoHorizonS = 1.5;
constexpr double kIndexHorizonS = 0.5;
constexpr double kEventHorizonS = 1.0;

using RowKey = std::tuple<std::int64_t, std::int64_t, std::int64_t>;  // device, connection, sequence

struct Rows {
  std::map<RowKey, std::int64_t> frames;        // kept camera frames -> host_ns
  std::map<RowKey, std::int64_t> pressure;      // pressure frames -> host_ns
  std::map<std::int64_t, std::int64_t> events;  // protocol event id -> host_ns
};

Rows read_rows(const fs::path& session) {
  Rows r;
  pvcap::sqlite::Database db(session / "session.db", pvcap::sqlite::Database::Mode::ReadOnly);
  auto f = db.prepare("SELECT device_id, connection, sequence, host_ns FROM frames WHERE kept = 1");
  while (f.step()) r.frames[{f.column_int(0), f.column_int(1), f.column_int(2)}] = f.column_int(3);
  auto p = db.prepare("SELECT device_id, connection, sequence, host_ns FROM pressure_frames");
  while (p.step()) r.pressure[{p.column_int(0), p.column_int(1), p.column_int(2)}] = p.column_int(3);
  auto e = db.prepare("SELECT id, host_ns FROM protocol_events");
  while (e.step()) r.events[e.column_int(0)] = e.column_int(1);
  return r;
}

// How long before the cut the earliest row of `truth` that the image lacks was received (0: none).
double lost_before_cut_s(const std::map<RowKey, std::int64_t>& truth, const std::map<RowKey, std::int64_t>& image,
                         std::int64_t cut_ns) {
  std::int64_t earliest = cut_ns;
  for (const auto& [key, host_ns] : truth)
    if (host_ns <= cut_ns && !image.count(key)) earliest = std::min(earliest, host_ns);
  return double(cut_ns - earliest) / 1e9;
}

std::uint64_t env_or(const char* name, std::uint64_t fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::strtoull(v, nullptr, 10) : fallback;
}

// A trace written by hand, as io_trace.c writes one: to hold the crash-image model to its rules.
class HandTrace {
 public:
  explicit HandTrace(fs::path dir) : dir_(std::move(dir)) { fs::create_directories(dir_); }
  HandTrace& op(std::uint32_t kind, const std::string& path, const std::string& bytes = "", std::int64_t offset = 0,
                std::uint32_t flags = 0, const std::string& path2 = "") {
    trace_record r{};
    r.magic = TRACE_MAGIC;
    r.op = kind;
    r.flags = flags;
    r.path_len = std::uint32_t(path.size());
    r.path2_len = std::uint32_t(path2.size());
    r.t_ns = std::int64_t(ops_.size());
    r.offset = offset;
    r.length = std::int64_t(bytes.size());
    r.data_pos = bytes.empty() ? -1 : std::int64_t(data_.size());
    data_ += bytes;
    ops_.append(reinterpret_cast<const char*>(&r), sizeof r).append(path).append(path2);
    return *this;
  }
  pvcap::power_cut::Trace write() const {
    std::ofstream(dir_ / "ops", std::ios::binary) << ops_;
    std::ofstream(dir_ / "data", std::ios::binary) << data_;
    return pvcap::power_cut::read_trace(dir_);
  }

 private:
  fs::path dir_;
  std::string ops_, data_;
};

// What each of 64 seeds left at `name` under the image of the whole trace ("" when absent).
std::set<std::string> outcomes(const pvcap::power_cut::Trace& t, const fs::path& root, const fs::path& work,
                               const std::string& name) {
  std::set<std::string> seen;
  for (std::uint64_t seed = 0; seed < 64; ++seed) {
    const fs::path image = work / fmt::format("image-{}", seed);
    pvcap::power_cut::build_crash_image(t, root, t.ops.size(), seed, image);
    seen.insert(fs::exists(image / name) ? "[" + read_all(image / name) + "]" : "");
    fs::remove_all(image);
  }
  return seen;
}

}  // namespace

TEST(CrashImage, WritesAfterTheLastFsyncAndNamesAfterTheFoldersLastSyncMayEachBeLost) {
  const fs::path work = work_dir("crash-image");
  const fs::path root = work / "root";
  // A file synced with its folder, then written again: its synced bytes always, the later write or not.
  {
    HandTrace h(work / "t1");
    h.op(TRACE_OPEN, (root / "a").string(), "", 0, TRACE_CREATED)
        .op(TRACE_WRITE, (root / "a").string(), "abc")
        .op(TRACE_SYNC, (root / "a").string())
        .op(TRACE_SYNC, root.string())
        .op(TRACE_WRITE, (root / "a").string(), "def", 3);
    EXPECT_EQ(outcomes(h.write(), root, work, "a"), (std::set<std::string>{"[abc]", "[abcdef]"}));
  }
  // Synced, but its folder never was: there with its bytes, or not there at all.
  {
    HandTrace h(work / "t2");
    h.op(TRACE_OPEN, (root / "b").string(), "", 0, TRACE_CREATED)
        .op(TRACE_WRITE, (root / "b").string(), "xyz")
        .op(TRACE_SYNC, (root / "b").string());
    EXPECT_EQ(outcomes(h.write(), root, work, "b"), (std::set<std::string>{"", "[xyz]"}));
  }
  // Renamed after the folder's last sync: under one name or the other, never both, never neither.
  {
    HandTrace h(work / "t3");
    h.op(TRACE_OPEN, (root / "c").string(), "", 0, TRACE_CREATED)
        .op(TRACE_WRITE, (root / "c").string(), "123")
        .op(TRACE_SYNC, (root / "c").string())
        .op(TRACE_SYNC, root.string())
        .op(TRACE_RENAME, (root / "c").string(), "", 0, 0, (root / "d").string());
    const auto t = h.write();
    std::set<std::string> seen;
    for (std::uint64_t seed = 0; seed < 64; ++seed) {
      const fs::path image = work / fmt::format("image-{}", seed);
      pvcap::power_cut::build_crash_image(t, root, t.ops.size(), seed, image);
      EXPECT_NE(fs::exists(image / "c"), fs::exists(image / "d")) << "seed " << seed;
      seen.insert(fs::exists(image / "c") ? "c" : "d");
      fs::remove_all(image);
    }
    EXPECT_EQ(seen, (std::set<std::string>{"c", "d"}));
  }
  // A cut before an op leaves it out: the image of t1's first four ops never has "def".
  {
    HandTrace h(work / "t4");
    h.op(TRACE_OPEN, (root / "a").string(), "", 0, TRACE_CREATED)
        .op(TRACE_WRITE, (root / "a").string(), "abc")
        .op(TRACE_SYNC, (root / "a").string())
        .op(TRACE_SYNC, root.string())
        .op(TRACE_WRITE, (root / "a").string(), "def", 3);
    const auto t = h.write();
    pvcap::power_cut::build_crash_image(t, root, 4, 1, work / "image");
    EXPECT_EQ(read_all(work / "image" / "a"), "abc");
  }
}

TEST(PowerCut, AProtocolSessionCutAtRandomWritesRecoversVerifiesAndLosesAtMostTheHorizon) {
  const std::uint64_t seed = env_or("PVCAP_POWER_CUT_SEED", std::random_device{}());
  const std::size_t points = env_or("PVCAP_POWER_CUT_POINTS", 8);
  std::printf("power cut: seed %llu (PVCAP_POWER_CUT_SEED=%llu repeats it), %zu cut points\n",
              static_cast<unsigned long long>(seed), static_cast<unsigned long long>(seed), points);
  const fs::path work = work_dir("power-cut");
  const fs::path root = work / "sessions", trace_dir = work / "trace";
  fs::create_directories(root);
  fs::create_directories(trace_dir);
  // Three force levels, both hands, two repetitions: twelve takes, about 30 s.
  const fs::path protocol = write_press_protocol(work, "[low, high, no_contact]", 0.5, 0.4, 3.0, 0.3);
  const auto r =
      run_pvcap(fmt::format("session --rig {} --root {} --protocol {} --auto --fast --participant T01 --skin-tone dark "
                            "--hand-order left_first",
                            write_protocol_rig(work).string(), root.string(), protocol.string()),
                fmt::format("PVCAP_IO_TRACE={} PVCAP_IO_TRACE_ROOT={} LD_PRELOAD={}", trace_dir.string(), root.string(),
                            PVCAP_IO_TRACE_LIB));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const fs::path truth_dir = only_session(root);
  ASSERT_FALSE(truth_dir.empty());
  const Rows truth = read_rows(truth_dir);
  ASSERT_GT(truth.events.size(), 20u);

  const auto trace = pvcap::power_cut::read_trace(trace_dir);
  const auto made = std::find_if(trace.ops.begin(), trace.ops.end(), [](const auto& op) {
    return op.op == TRACE_OPEN && op.path.size() > 11 && op.path.compare(op.path.size() - 11, 11, "/session.db") == 0;
  });
  ASSERT_NE(made, trace.ops.end()) << "the trace never saw session.db made";
  const std::int64_t t_first = made->t_ns, t_last = trace.ops.back().t_ns;
  std::printf(
      "trace: %zu writes, syncs and name changes over %.1f s; the session kept %zu camera frames, %zu "
      "pressure frames, %zu protocol events\n",
      trace.ops.size(), (t_last - t_first) / 1e9, truth.frames.size(), truth.pressure.size(), truth.events.size());
  EXPECT_GT(t_last - t_first, 25'000'000'000) << "a 30-s session";

  std::mt19937_64 rng(seed);
  std::vector<double> worst;
  for (std::size_t k = 0; k < points; ++k) {
    // A moment drawn uniformly over the session's life, cut just before the first op at or after it.
    const std::int64_t at = std::uniform_int_distribution<std::int64_t>(t_first, t_last)(rng);
    const std::size_t cut = std::size_t(std::lower_bound(trace.ops.begin(), trace.ops.end(), at,
                                                         [](const auto& op, std::int64_t t) { return op.t_ns < t; }) -
                                        trace.ops.begin());
    // The power went between the last op made and this one: losses are counted from this one's time
    // (the harsher reading).
    const std::int64_t cut_ns = cut < trace.ops.size() ? trace.ops[cut].t_ns : t_last;
    SCOPED_TRACE(fmt::format("cut {} at op {} of {}, {:.2f} s in (seed {})", k, cut, trace.ops.size(),
                             (cut_ns - t_first) / 1e9, seed));
    const fs::path image = work / fmt::format("cut-{}", k);
    const auto counts = pvcap::power_cut::build_crash_image(trace, root, cut, seed + k, image);
    const fs::path session = image / truth_dir.filename();
    if (!fs::exists(session / "session.db")) {
      // Only a cut before the first sync of the session folder may leave it without its index.
      EXPECT_LT(double(cut_ns - t_first) / 1e9, kVideoHorizonS) << "the session folder is gone";
      fs::remove_all(image);
      continue;
    }
    const auto recovered = run_pvcap("--log-level warn recover " + session.string());
    EXPECT_EQ(recovered.exit_code, 0) << recovered.output;
    const auto verified = run_pvcap("--log-level off verify " + session.string());
    EXPECT_TRUE(verified.exit_code == 0 || verified.exit_code == 3) << verified.output;
    EXPECT_EQ(verified.output.find("ERROR"), std::string::npos) << verified.output;

    auto reader = pvcap::SessionReader::open(session);
    if (!reader) {
      ADD_FAILURE() << reader.error().message;
      fs::remove_all(image);
      continue;
    }
    reader.value()->set_check_checksums(true);
    std::size_t read = 0;
    for (std::size_t i = 0; i < reader.value()->sample_count(); ++i) {
      auto s = reader.value()->sample(i);
      if (!s) {
        ADD_FAILURE() << "sample " << i << ": " << s.error().message;
        break;
      }
      ++read;
    }
    const Rows got = read_rows(session);
    const double cameras_s = lost_before_cut_s(truth.frames, got.frames, cut_ns);
    const double pressure_s = lost_before_cut_s(truth.pressure, got.pressure, cut_ns);
    EXPECT_LE(cameras_s, kVideoHorizonS) << "camera frames lost before the cut";
    EXPECT_LE(pressure_s, kIndexHorizonS) << "pressure frames lost before the cut";
    std::size_t events_due = 0;
    for (const auto& [id, host_ns] : truth.events) {
      if (host_ns > cut_ns - std::int64_t(kEventHorizonS * 1e9)) continue;
      ++events_due;
      EXPECT_TRUE(got.events.count(id)) << "protocol event " << id << ", " << (cut_ns - host_ns) / 1e9
                                        << " s before the cut, is gone";
    }
    std::printf(
        "cut %zu at %.2f s: cameras lost %.3f s, pressure %.3f s before it; %zu events due, %zu samples read; "
        "after the last sync %zu writes (%zu kept, %zu torn, %zu dropped), %zu name changes (%zu kept); "
        "verify exit %d\n",
        k, (cut_ns - t_first) / 1e9, cameras_s, pressure_s, events_due, read, counts.writes_after_sync, counts.kept,
        counts.torn, counts.dropped, counts.names_after_sync, counts.names_kept, verified.exit_code);
    std::fflush(stdout);
    worst.push_back(std::max(cameras_s, pressure_s));
    fs::remove_all(image);
  }
  ASSERT_FALSE(worst.empty());
  std::sort(worst.begin(), worst.end());
  std::printf("power cut: %zu cut points, lost at most %.3f s before the cut, median %.3f s (seed %llu)\n",
              worst.size(), worst.back(), worst[worst.size() / 2], static_cast<unsigned long long>(seed));
}
