// `pvcap replay --as-devices` round trip: a short simulated session (four cameras with drifting,
// offset clocks, a Sensel) is re-served through the fake cameras and the Sensel emulator, and a
// `pvcap session` on the printed rig records it again. The re-recording must name the same camera
// frames and the same pressure frame for (nearly) every sample, store bit-identical mosaics and
// pressure payloads, and have received the frames at the recorded intervals.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "storage/index/database.h"
#include "storage/index/session_reader.h"
#include "tests/integration/session_under_test.h"

namespace fs = std::filesystem;
using pvcap::SessionReader;
using pvcap::testing::only_session;
using pvcap::testing::run_pvcap;
using pvcap::testing::sim_rig_yaml;
using pvcap::testing::work_dir;
namespace sqlite = pvcap::sqlite;

namespace {

// A sample as the two recordings can be compared: each camera's frame (by camera name: frame id and
// device time) and the pressure frame's payload and device time, with the instants it was grouped
// (tick) and paired (t) at.
struct SampleKey {
  std::int64_t index = 0;  // SessionReader's position
  std::int64_t tick_ns = 0, t_ns = 0;
  std::map<std::string, std::pair<std::int64_t, std::int64_t>> cameras;  // name -> (frame_id, device_ns)
  std::vector<std::uint8_t> pressure;
  std::int64_t pressure_device_ns = 0;
};

// A recording as the test reads it: its samples, and every frame's instant on its clock, by stream
// name ("pressure" for the Sensel) and device time.
struct Recorded {
  std::vector<SampleKey> samples;
  std::map<std::pair<std::string, std::int64_t>, std::int64_t> mapped_ns;
};

Recorded read_recorded(const fs::path& session) {
  sqlite::Database db(session / "session.db", sqlite::Database::Mode::ReadOnly);
  Recorded r;
  auto& out = r.samples;
  std::map<std::int64_t, std::size_t> by_id;
  auto s = db.prepare(
      "SELECT s.id, s.tick_ns, s.t_ns, p.payload, p.device_ns FROM samples s LEFT JOIN pressure_frames p ON "
      "p.device_id = s.pressure_device_id AND p.connection = s.pressure_connection AND p.sequence = "
      "s.pressure_sequence ORDER BY s.id");
  while (s.step()) {
    by_id[s.column_int(0)] = out.size();
    SampleKey k;
    k.index = std::int64_t(out.size());
    k.tick_ns = s.column_int(1);
    k.t_ns = s.column_int(2);
    if (!s.column_null(3)) k.pressure = s.column_blob(3), k.pressure_device_ns = s.column_int(4);
    out.push_back(std::move(k));
  }
  auto m = db.prepare(
      "SELECT sf.sample_id, d.name, f.frame_id, f.device_ns FROM sample_frames sf JOIN devices d ON d.id = "
      "sf.device_id JOIN frames f ON f.device_id = sf.device_id AND f.connection = sf.connection AND f.sequence = "
      "sf.sequence");
  while (m.step()) out[by_id.at(m.column_int(0))].cameras[m.column_text(1)] = {m.column_int(2), m.column_int(3)};
  auto f = db.prepare(
      "SELECT d.name, f.device_ns, f.mapped_ns FROM frames f JOIN devices d ON d.id = f.device_id WHERE f.mapped_ns "
      "IS NOT NULL");
  while (f.step()) r.mapped_ns[{f.column_text(0), f.column_int(1)}] = f.column_int(2);
  auto p = db.prepare("SELECT device_ns, mapped_ns FROM pressure_frames WHERE mapped_ns IS NOT NULL");
  while (p.step()) r.mapped_ns[{"pressure", p.column_int(0)}] = p.column_int(1);
  return r;
}

// The q-quantile of v (0 when empty).
double pct(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[std::min(v.size() - 1, std::size_t(double(v.size()) * q))];
}

// A camera's replay log (sim-truth/camN_replay.csv): per frame, what it was, when it was due,
// when it left, when the engine entered the fill, when its stored image was at hand (host ns).
struct ReplayedFrame {
  std::int64_t frame_id, device_ns, due_ns, sent_ns, entered_ns, image_ns;
};
// A replay log's rows of integers, its header line skipped.
std::vector<std::vector<std::int64_t>> integer_rows(const fs::path& log) {
  std::ifstream in(log);
  std::string line;
  std::getline(in, line);
  std::vector<std::vector<std::int64_t>> rows;
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string field;
    auto& v = rows.emplace_back();
    while (std::getline(ss, field, ',')) v.push_back(std::stoll(field));
  }
  return rows;
}

std::vector<ReplayedFrame> read_camera_replay_log(const fs::path& log) {
  std::vector<ReplayedFrame> frames;  // frame_id,device_ns,due_ns,sent_ns,entered_ns,image_ns
  for (const auto& v : integer_rows(log))
    if (v.size() >= 6) frames.push_back({v[0], v[1], v[2], v[3], v[4], v[5]});
  return frames;
}

// Two frames' recorded device interval (ns).
double recorded_interval_ns(const ReplayedFrame& before, const ReplayedFrame& f) {
  return double(f.device_ns - before.device_ns);
}

// The Sensel's replay log (sim-truth/sensel_replay.csv): per frame, its row (its 8-bit counter
// repeats), its device clock (32-bit microseconds), when it was due, when it left, when pvcap's
// request for it came and when the emulator's thread woke from waiting for it to be due (host ns).
struct ReplayedPressure {
  std::int64_t row, device_us, due_ns, sent_ns, asked_ns, woke_ns;
};
std::vector<ReplayedPressure> read_sensel_replay_log(const fs::path& log) {
  std::vector<ReplayedPressure> frames;  // counter,device_us,due_ns,sent_ns,asked_ns,woke_ns
  for (const auto& v : integer_rows(log))
    if (v.size() >= 6) frames.push_back({std::int64_t(frames.size()), v[1], v[2], v[3], v[4], v[5]});
  return frames;
}

double recorded_interval_ns(const ReplayedPressure& before, const ReplayedPressure& f) {
  return double(std::uint32_t(std::uint64_t(f.device_us) - std::uint64_t(before.device_us))) * 1e3;
}

// When a frame's sending could begin: a camera's when the engine entered its fill; the Sensel's
// when both pvcap's request had come and the emulator's thread had woken. Later than due, that is
// the host's late wake (or the recorder's late request), not the replay's.
std::int64_t start_ns(const ReplayedFrame& f) { return f.entered_ns; }
std::int64_t start_ns(const ReplayedPressure& f) { return std::max(f.asked_ns, f.woke_ns); }
template <class Frame>
std::int64_t late_start_ns(const Frame& f) {
  return std::max<std::int64_t>(0, start_ns(f) - f.due_ns);
}

// |interval between two frames leaving the replay - their recorded device interval| (ms).
template <class Frame>
double interval_error_ms(const Frame& before, const Frame& f) {
  return std::fabs(double(f.sent_ns - before.sent_ns) - recorded_interval_ns(before, f)) / 1e6;
}
// The replay's own share of it (ms): the same error with each frame's late start taken out, i.e.
// between the instants the frames would have left had the host woken them on time. What remains
// is the replay's schedule and its fill or send.
template <class Frame>
double own_interval_error_ms(const Frame& before, const Frame& f) {
  const double sent = double((f.sent_ns - late_start_ns(f)) - (before.sent_ns - late_start_ns(before)));
  return std::fabs(sent - recorded_interval_ns(before, f)) / 1e6;
}

std::int64_t frame_number(const ReplayedFrame& f) { return f.frame_id; }
std::int64_t frame_number(const ReplayedPressure& f) { return f.row; }

// A log's timing in three parts (ms): the interval errors as sent, the replay's own share of each,
// and how late each frame's start came (the host's).
struct IntervalTiming {
  std::vector<double> sent, own, late_start, recorded;  // recorded: the intervals themselves
  void add(const IntervalTiming& o) {
    recorded.insert(recorded.end(), o.recorded.begin(), o.recorded.end());
    sent.insert(sent.end(), o.sent.begin(), o.sent.end());
    own.insert(own.end(), o.own.begin(), o.own.end());
    late_start.insert(late_start.end(), o.late_start.begin(), o.late_start.end());
  }
};
template <class Frame>
IntervalTiming interval_timing(const std::vector<Frame>& frames) {
  IntervalTiming t;
  for (std::size_t i = 1; i < frames.size(); ++i) {
    t.sent.push_back(interval_error_ms(frames[i - 1], frames[i]));
    t.own.push_back(own_interval_error_ms(frames[i - 1], frames[i]));
    t.late_start.push_back(double(late_start_ns(frames[i])) / 1e6);
    t.recorded.push_back(recorded_interval_ns(frames[i - 1], frames[i]) / 1e6);
  }
  return t;
}
IntervalTiming camera_timing(const fs::path& log) { return interval_timing(read_camera_replay_log(log)); }
IntervalTiming sensel_timing(const fs::path& log) { return interval_timing(read_sensel_replay_log(log)); }

// Prints a stream's timing, and bounds what is the replay's: its own share of the interval error
// (its schedule and its fill or send: p50 under 0.5 ms, p95 under 1 ms. A full run of 2026-12-07
// put a trigger line's p95 at 0.80 ms, alone on the machine, with starts up to 7.2 ms late: the host
// preempting the fill's copy; the same test then gave 0.16-0.35 ms three times. An engine's stall or
// a missed trigger is a period, 33 ms.) How late the host started the
// frames is not the replay's (this VM wakes an idle core up to 3.7 ms late, a real-time thread
// too; in CI's loaded runs starts came 1-18 ms late and moved the intervals as sent to p50 0.57,
// p95 6.1 ms: docs/replay.md, "Timing"), so for a camera it is only guarded against gross
// failures: at p95 under half the stream's period. The engine's stall (1 frame in 8-12 a period
// late or more) or a missed trigger fails that; a slow wake does not. The Sensel's late starts are
// the recorder's late requests and the host's wake, nothing of the replay's (at rate 2, its period
// 4 ms, a loaded machine put them at p95 13 ms): printed only. The intervals as sent are printed,
// not bounded.
enum class LateStarts { Guarded, Printed };
void expect_replay_timing(const std::string& what, const IntervalTiming& t, const std::string& late,
                          LateStarts late_starts = LateStarts::Guarded) {
  const double period = pct(t.recorded, 0.5);
  std::printf(
      "%s: |interval sent - recorded| p50 %.3f p95 %.3f p99 %.3f ms; the replay's own share p50 %.3f p95 %.3f ms; "
      "started late p50 %.3f p95 %.3f max %.3f ms (%zu intervals of %.2f ms)\n",
      what.c_str(), pct(t.sent, 0.5), pct(t.sent, 0.95), pct(t.sent, 0.99), pct(t.own, 0.5), pct(t.own, 0.95),
      pct(t.late_start, 0.5), pct(t.late_start, 0.95), pct(t.late_start, 1.0), t.sent.size(), period);
  EXPECT_LT(pct(t.own, 0.5), 0.5) << what << ": intervals more than 1 ms off:" << late;
  EXPECT_LT(pct(t.own, 0.95), 1.0) << what << ": intervals more than 1 ms off:" << late;
  if (late_starts == LateStarts::Guarded) {
    EXPECT_LT(pct(t.late_start, 0.95), period / 2) << what << ": intervals more than 1 ms off:" << late;
  }
}

// The frames whose interval missed its recorded one by more than `late_ms`, each with where its
// time went (`anatomy`: ms from the instant it was due), so a failed bound says what was late.
template <class Frame, class Anatomy>
std::string late_frames(const fs::path& log, const std::vector<Frame>& frames, double late_ms, Anatomy anatomy) {
  std::string out;
  for (std::size_t i = 1; i < frames.size(); ++i) {
    const double error_ms = interval_error_ms(frames[i - 1], frames[i]);
    if (error_ms > late_ms)
      out += fmt::format("\n  {}: frame {}: interval off by {:.3f} ms; {}", log.filename().string(),
                         frame_number(frames[i]), error_ms, anatomy(frames[i]));
  }
  return out;
}
double ms_after(std::int64_t ns, std::int64_t due_ns) { return double(ns - due_ns) / 1e6; }

// A camera's: whether the engine woke late (entered), the image was late, or the frame left late.
std::string late_camera_frames(const fs::path& log, double late_ms) {
  return late_frames(log, read_camera_replay_log(log), late_ms, [](const ReplayedFrame& f) {
    return fmt::format("entered {:+.3f}, image {:+.3f}, left {:+.3f} ms", ms_after(f.entered_ns, f.due_ns),
                       ms_after(f.image_ns, f.due_ns), ms_after(f.sent_ns, f.due_ns));
  });
}
// The Sensel's: a late request is pvcap's reader (or its core) waking late, a late wake the host
// waking the emulator's thread late from its wait for the frame to be due, a late send after both
// the emulator's own.
std::string late_sensel_frames(const fs::path& log, double late_ms) {
  return late_frames(log, read_sensel_replay_log(log), late_ms, [](const ReplayedPressure& f) {
    return fmt::format("asked {:+.3f}, woke {:+.3f}, left {:+.3f} ms", ms_after(f.asked_ns, f.due_ns),
                       ms_after(f.woke_ns, f.due_ns), ms_after(f.sent_ns, f.due_ns));
  });
}

// What the emulator itself adds: from the latest of due, pvcap's request and its thread's wake to
// the frame leaving (ms): the cameras' fill, for the Sensel.
std::vector<double> sensel_own_delays_ms(const fs::path& log) {
  std::vector<double> out;
  for (const ReplayedPressure& f : read_sensel_replay_log(log))
    out.push_back(double(f.sent_ns - std::max({f.due_ns, f.asked_ns, f.woke_ns})) / 1e6);
  return out;
}

// How long each frame took to leave once its fill had begun and it was due (ms, sent -
// max(entered, due)): the replay's own time (its image, its copy), without the host's wake of the
// engine, which is not the replay's.
std::vector<double> fill_delays_ms(const fs::path& log) {
  std::vector<double> delays;
  for (const ReplayedFrame& f : read_camera_replay_log(log))
    delays.push_back(double(f.sent_ns - std::max(f.due_ns, f.entered_ns)) / 1e6);
  return delays;
}

// Cameras' replay logs pooled: their timing, each frame's fill (fill_delays_ms) and the frames whose
// interval missed by more than `late_ms`, for a failure's message.
struct CameraLogs {
  IntervalTiming timing;
  std::vector<double> fill;
  std::string late;
  // Adds `log`; its own timing, for a per-camera check.
  IntervalTiming add(const fs::path& log, double late_ms) {
    const IntervalTiming t = camera_timing(log);
    timing.add(t);
    for (double d : fill_delays_ms(log)) fill.push_back(d);
    late += late_camera_frames(log, late_ms);
    return t;
  }
};

// A session a test replays: its rig file and length, recorded by the test itself, alone (RUN_SERIAL:
// recorded beside other tests, an original held picks its re-recording did not repeat; docs/testing.md).
struct OriginalSpec {
  std::string rig_yaml;
  double seconds;
};

// Records original `spec` under `dir` (dir/recorded/<session>); its session folder, or empty with
// the failure said.
fs::path record_original(const fs::path& dir, const OriginalSpec& spec) {
  fs::create_directories(dir);
  std::ofstream(dir / "rig.yaml") << spec.rig_yaml;
  const auto first = run_pvcap(fmt::format("session --rig {} --root {} --duration {} --no-web",
                                           (dir / "rig.yaml").string(), (dir / "recorded").string(), spec.seconds));
  const fs::path session = only_session(dir / "recorded");
  if (first.exit_code != 0 || session.empty()) {
    ADD_FAILURE() << "recording the original: " << first.output;
    return {};
  }
  return session;
}

// Replays `original` as devices and records that for `again_seconds`, or for the duration the replay
// printed (as a user would run it) when none is given: the two sessions, the printed duration and
// the re-recording's output (empty paths, with the failure said, on an error).
struct RoundTrip {
  fs::path recorded, replayed, replay_rig;
  std::string rig_output, again_output;
  double printed_seconds = 0;  // the duration in the printed `pvcap session` command; 0 when none
};
RoundTrip replay_and_record(const fs::path& work, const OriginalSpec& original, std::optional<double> again_seconds,
                            const std::string& replay_options = "") {
  RoundTrip r;
  r.recorded = record_original(work / "original", original);
  if (r.recorded.empty()) return {};
  r.replay_rig = work / "replay.yaml";
  const auto rig = run_pvcap(fmt::format("replay {} --as-devices --rig-out {} {}", r.recorded.string(),
                                         r.replay_rig.string(), replay_options));
  r.rig_output = rig.output;
  if (rig.exit_code != 0) {
    ADD_FAILURE() << rig.output;
    return {};
  }
  const std::string printed = "pvcap session --rig " + r.replay_rig.string() + " --duration ";
  if (const auto at = rig.output.find(printed); at != std::string::npos)
    r.printed_seconds = std::stod(rig.output.substr(at + printed.size()));
  if (!again_seconds && r.printed_seconds <= 0) {
    ADD_FAILURE() << "no `" << printed << "` command printed:\n" << rig.output;
    return {};
  }
  const auto again = run_pvcap(fmt::format("session --rig {} --root {} --duration {} --no-web", r.replay_rig.string(),
                                           (work / "replayed").string(), again_seconds.value_or(r.printed_seconds)));
  r.again_output = again.output;
  r.replayed = only_session(work / "replayed");
  if (again.exit_code != 0 || r.replayed.empty()) {
    ADD_FAILURE() << again.output;
    return {};
  }
  return r;
}

// A frame's instant in a recording (its mapped time), by stream name and device time.
std::optional<double> instant(const Recorded& r, const std::string& stream, std::int64_t device_ns) {
  const auto it = r.mapped_ns.find({stream, device_ns});
  if (it == r.mapped_ns.end()) return std::nullopt;
  return double(it->second);
}

// How near a tie an original's choice was, and how far the re-recording moved the instants it
// compares: margin <= moved is a tie broken the other way (docs/replay.md).
struct Decision {
  double margin = 0, moved = 0;
  bool tie() const { return margin <= moved; }
};

// The re-recording's clock is the original's plus whole sample periods: the median of the tick
// shifts of the samples that hold a frame found in both.
std::int64_t replay_shift(const Recorded& ra, const Recorded& rb) {
  std::map<std::pair<std::string, std::int64_t>, std::int64_t> b_tick_by_frame;
  for (const auto& s : rb.samples)
    for (const auto& [name, frame] : s.cameras) b_tick_by_frame[{name, frame.second}] = s.tick_ns;
  std::vector<std::int64_t> shifts;
  for (const auto& s : ra.samples)
    for (const auto& [name, frame] : s.cameras)
      if (auto it = b_tick_by_frame.find({name, frame.second}); it != b_tick_by_frame.end())
        shifts.push_back(it->second - s.tick_ns);
  if (shifts.empty()) return 0;
  std::nth_element(shifts.begin(), shifts.begin() + std::ptrdiff_t(shifts.size() / 2), shifts.end());
  return shifts[shifts.size() / 2];
}

// A tick takes the group whose time (the mean of its frames' instants) is nearest. Where a session's
// ticks lie near half way between two groups (cameras at 30 fps, ticks at 15 Hz; the simulated
// cameras' frames keep one phase against the sample lattice for as long as the host's real-time and
// monotonic clocks keep theirs, so a host can sit near that tie for hours), the re-recording's tick
// may take the other neighbour: then no frame of the original's sample `s` is in any sample of the
// re-recording. Its decision against the group the re-recording's tick took, both seen on both
// clocks; none when that tick has no sample or a frame is not in both recordings.
std::optional<Decision> tick_decision(const Recorded& ra, const Recorded& rb, std::int64_t shift, const SampleKey& s) {
  const SampleKey* y = nullptr;
  for (const auto& b : rb.samples)
    if (b.tick_ns - shift == s.tick_ns) y = &b;
  if (!y) return std::nullopt;
  auto group_time = [](const Recorded& r, const SampleKey& g, double minus) -> std::optional<double> {
    double sum = 0;
    for (const auto& [name, frame] : g.cameras) {
      const auto t = instant(r, name, frame.second);
      if (!t) return std::nullopt;
      sum += *t - minus;
    }
    if (g.cameras.empty()) return std::nullopt;
    return sum / double(g.cameras.size());
  };
  const auto x_then = group_time(ra, s, 0), y_then = group_time(ra, *y, 0);
  const auto x_again = group_time(rb, s, double(shift)), y_again = group_time(rb, *y, double(shift));
  if (!x_then || !y_then || !x_again || !y_again) return std::nullopt;
  const double tick = double(s.tick_ns);
  return Decision{std::fabs(*y_then - tick) - std::fabs(*x_then - tick),
                  std::fabs(*y_again - *y_then) + std::fabs(*x_again - *x_then)};
}

}  // namespace

TEST(ReplayAsDevices, TheReRecordedSessionHasTheSameSamplesFramesAndPayloads) {
  const fs::path work = work_dir("replay-devices");
  // 8 s, four drifting cameras and the Sensel, recorded again for the printed duration.
  const RoundTrip trip = replay_and_record(work,
                                           {sim_rig_yaml({{.drift_ppm = 40, .offset_ms = 5000},
                                                          {.drift_ppm = -65, .offset_ms = 12500},
                                                          {.drift_ppm = 90, .offset_ms = 800},
                                                          {.drift_ppm = -15, .offset_ms = 31000}},
                                                         640, 480, 30, 15, "free-run", /*sensel=*/true),
                                            8},
                                           std::nullopt);
  ASSERT_FALSE(trip.replayed.empty());
  const fs::path &recorded = trip.recorded, &replayed = trip.replayed;
  const std::string& again_output = trip.again_output;
  EXPECT_GT(trip.printed_seconds, 8.0);
  EXPECT_LT(trip.printed_seconds, 9.0);
  // The printed duration ends the session before the cameras fall silent (sim::ReplayRig::record_seconds).
  EXPECT_EQ(again_output.find("camera lost"), std::string::npos) << "the session ends before the replay falls silent:\n"
                                                                 << again_output;

  // Every recorded sample, found in the re-recording by any of its camera frames, names the same
  // frame of every camera and the same pressure frame.
  const Recorded ra_ = read_recorded(recorded), rb_ = read_recorded(replayed);
  const auto &a = ra_.samples, &b = rb_.samples;
  ASSERT_GT(a.size(), 100u);
  std::map<std::pair<std::string, std::int64_t>, const SampleKey*> b_by_frame;
  for (const auto& s : b)
    for (const auto& [name, frame] : s.cameras) b_by_frame[{name, frame.second}] = &s;

  // The re-recording's clock is the original's plus whole sample periods: how well does it put every
  // frame where the original did? (The Sensel's part includes the emulator's pseudo-terminal latency,
  // which the recording's own latency floor absorbed and the replay adds again: docs/replay.md.)
  const std::int64_t shift = replay_shift(ra_, rb_);
  ASSERT_NE(shift, 0) << "no frame of the original is in a sample of the re-recording";
  const double period_ns = 1e9 / 15.0;
  EXPECT_LT(std::fabs(double(shift) / period_ns - std::round(double(shift) / period_ns)), 1e-6)
      << "the replay is shifted by whole sample periods";
  std::map<std::string, std::vector<double>> moved_us;  // per stream: |instant again - instant then| (us)
  for (const auto& [key, t] : ra_.mapped_ns)
    if (auto it = rb_.mapped_ns.find(key); it != rb_.mapped_ns.end())
      moved_us[key.first].push_back(std::fabs(double(it->second - shift - t)) / 1e3);
  // How far apart a re-recording puts a frame: tens of microseconds (a camera's clock is fitted to
  // its latch probes afresh; the Sensel's pseudo-terminal adds its floor again, 60-80 us); p95
  // 20-110 us measured on 2026-11-26, loaded or not. It is the replay's precision, which the tie
  // rule below compares each differing pick against.
  for (const auto& [stream, v] : moved_us) {
    std::printf("re-recorded instants, %s: |again - then| p50 %.1f p95 %.1f us (%zu frames)\n", stream.c_str(),
                pct(v, 0.5), pct(v, 0.95), v.size());
    EXPECT_LT(pct(v, 0.95), 500.0) << stream;
  }

  // A pick that differs is a tie broken the other way only when the re-recording moved the instants
  // the decision compares by at least the original's own margin. Pairing takes the pressure frame
  // nearest the sample's instant t: picking y over the original's x again implies
  //   (|y - t| - |x - t|)  <=  |dy - dt| + |dx - dt|
  // (d = instant again less instant then; the replay's whole-period shift cancels), so a difference
  // with a larger margin is a pairing fault. Grouping puts a camera's frame with the anchor (a
  // group's earliest frame) it is nearer, within half a frame period; at one frame rate that is the
  // same bound for the camera's two frames, with a frame both groups share in place of t; a camera the
  // re-recording left out of the group was at that limit within what it moved. (The simulated Morph scans every 8 ms
  // against a 66.7 ms grid: the same three phases recur, so a third of a session's samples can sit within tens of
  // microseconds of a tie.) Anything else counts against the 99 %, and is said with its figures.
  std::vector<double> tie_margins_us;  // how near a tie the original's choice was, for those broken
  std::string differences;             // each sample not explained, and why (also in the failure message)
  // The original's margin for x over y as seen from `at`, and what the re-recording moved them
  // against it.
  auto decision = [&](const std::string& stream, std::int64_t x_device, std::int64_t y_device, double at_then,
                      double at_again) -> std::optional<Decision> {
    const auto x = instant(ra_, stream, x_device), y = instant(ra_, stream, y_device);
    const auto xa = instant(rb_, stream, x_device), ya = instant(rb_, stream, y_device);
    if (!x || !y || !xa || !ya) return std::nullopt;
    const double d_at = at_again - at_then;
    return Decision{std::fabs(*y - at_then) - std::fabs(*x - at_then),
                    std::fabs(*ya - *y - d_at) + std::fabs(*xa - *x - d_at)};
  };
  const double group_limit_ns = 0.5e9 / 30.0;  // half the cameras' frame period (30 fps above)
  // A frame the original picked that the replay never sent (it was due before that device began
  // streaming: the recorder was not listening yet) cannot be picked again: such samples are not
  // comparable, and are counted apart.
  auto sent_again = [&](const std::string& stream, std::int64_t device_ns) {
    return rb_.mapped_ns.count({stream, device_ns}) > 0;
  };
  std::size_t same = 0, pressure_same = 0, ties = 0, different = 0, not_sent = 0;
  std::vector<std::pair<std::int64_t, std::int64_t>> matched;  // sample indexes, recorded -> replayed
  for (const auto& s : a) {
    bool comparable = s.pressure.empty() || sent_again("pressure", s.pressure_device_ns);
    for (const auto& [name, frame] : s.cameras) comparable = comparable && sent_again(name, frame.second);
    if (!comparable) {
      ++not_sent;
      continue;
    }
    const SampleKey* twin = nullptr;
    for (const auto& [name, frame] : s.cameras)
      if (auto it = b_by_frame.find({name, frame.second}); it != b_by_frame.end()) twin = it->second;
    if (!twin) {
      const auto d = tick_decision(ra_, rb_, shift, s);  // the tick took the neighbouring group?
      if (d && d->tie()) {
        tie_margins_us.push_back(d->margin / 1e3);
        ++ties;
        continue;
      }
      ++different;
      differences += fmt::format(
          "sample {} ({} of {}): none of its frames is in a sample of the re-recording; {}\n", s.index,
          std::size_t(&s - a.data()) + 1, a.size(),
          d ? fmt::format(
                  "the tick took another group, the original's nearer by {:.0f} us, the instants moved {:.0f} us",
                  d->margin / 1e3, d->moved / 1e3)
            : std::string("no sample at its tick, or a frame not in both recordings"));
      continue;
    }
    const bool cameras_same = twin->cameras == s.cameras;
    pressure_same += twin->pressure == s.pressure;
    if (cameras_same && twin->pressure == s.pressure) {
      ++same;
      matched.emplace_back(s.index, twin->index);
      continue;
    }
    std::string why;
    if (twin->pressure != s.pressure) {
      const auto d = s.pressure.empty() || twin->pressure.empty()
                         ? std::nullopt
                         : decision("pressure", s.pressure_device_ns, twin->pressure_device_ns, double(s.t_ns),
                                    double(twin->t_ns));
      if (d && d->tie())
        tie_margins_us.push_back(d->margin / 1e3);
      else
        why += d ? fmt::format(" pressure: the original's frame nearer by {:.0f} us, the instants moved {:.0f} us;",
                               d->margin / 1e3, d->moved / 1e3)
                 : std::string(" pressure: one of the two has none, or a frame is not in both recordings;");
    }
    for (const auto& [name, frame] : s.cameras) {
      const auto it = twin->cameras.find(name);
      if (it != twin->cameras.end() && it->second == frame) continue;
      // The anchors it may have been grouped against: frames of other cameras both groups hold.
      std::optional<Decision> best;  // the nearest to a tie over all shared anchors
      for (const auto& [other, shared] : s.cameras) {
        const auto o = twin->cameras.find(other);
        if (other == name || o == twin->cameras.end() || o->second != shared) continue;
        const auto at = instant(ra_, other, shared.second), at_again = instant(rb_, other, shared.second);
        if (!at || !at_again) continue;
        std::optional<Decision> d;
        if (it != twin->cameras.end()) {
          d = decision(name, frame.second, it->second.second, *at, *at_again);
        } else if (const auto x = instant(ra_, name, frame.second), xa = instant(rb_, name, frame.second); x && xa) {
          d = Decision{group_limit_ns - std::fabs(*x - *at), std::fabs(*xa - *x - (*at_again - *at))};  // at the limit
        }
        if (d && (!best || d->margin - d->moved < best->margin - best->moved)) best = d;
      }
      if (best && best->tie()) {
        tie_margins_us.push_back(best->margin / 1e3);
      } else {
        why += best ? fmt::format(" {}: {} by {:.0f} us, the instants moved {:.0f} us;", name,
                                  it == twin->cameras.end() ? "left out of its group, inside the limit"
                                                            : "the original's frame nearer the anchor",
                                  best->margin / 1e3, best->moved / 1e3)
                    : fmt::format(" {}: {} and no frame of another camera is in both groups;", name,
                                  it == twin->cameras.end() ? "left out" : "another frame");
      }
    }
    if (why.empty()) {
      ++ties;
    } else {
      ++different;  // said, and counted against the 99 % below (a frame lost under load regroups a few)
      differences += fmt::format("sample {} names other frames in the re-recording, not at a tie:{}\n", s.index, why);
    }
  }
  std::fputs(differences.c_str(), stdout);
  const std::size_t compared = a.size() - not_sent;
  const double same_pct = 100.0 * double(same) / double(compared);
  std::sort(tie_margins_us.begin(), tie_margins_us.end());
  std::printf(
      "as-devices round trip: %zu of %zu samples name the same camera frames and pressure frame "
      "(%.2f %%; pressure alone %zu); %zu more broke a tie the other way (the original's pick was nearer by "
      "no more than the re-recording moved the instants; by at most %.0f us); %zu differ; %zu not compared (a "
      "frame they name was due before its device streamed again)\n",
      same, compared, same_pct, pressure_same, ties, tie_margins_us.empty() ? 0.0 : tie_margins_us.back(), different,
      not_sent);
  EXPECT_LE(not_sent, 3u) << "only the session's first moments";
  EXPECT_GE(100.0 * double(same + ties) / double(compared), 99.0) << differences << "the re-recording said:\n"
                                                                  << again_output;

  // Every recorded pressure payload up to the cameras' last frame (what a sample can hold, and what the
  // printed duration re-records; the Sensel recorded on while the cameras stopped) came back bit for bit.
  {
    sqlite::Database da(recorded / "session.db", sqlite::Database::Mode::ReadOnly);
    sqlite::Database db(replayed / "session.db", sqlite::Database::Mode::ReadOnly);
    std::set<std::vector<std::uint8_t>> replayed_payloads;
    auto qb = db.prepare("SELECT payload FROM pressure_frames");
    while (qb.step()) replayed_payloads.insert(qb.column_blob(0));
    std::size_t total = 0, found = 0;
    auto qa = da.prepare(
        "SELECT payload FROM pressure_frames WHERE mapped_ns <= (SELECT max(mapped_ns) FROM frames WHERE mapped_ns IS "
        "NOT NULL)");
    while (qa.step()) {
      ++total;
      found += replayed_payloads.count(qa.column_blob(0));
    }
    std::printf("pressure payloads: %zu of %zu recorded frames re-recorded bit for bit\n", found, total);
    EXPECT_GE(found * 100, total * 99);
    EXPECT_GT(total, 800u);
  }

  // The stored mosaics of the matched samples are bit-identical (every 4th sample, every camera).
  {
    auto ra = SessionReader::open(recorded), rb = SessionReader::open(replayed);
    ASSERT_TRUE(ra && rb);
    std::size_t compared = 0, identical = 0;
    for (std::size_t i = 0; i < matched.size(); i += 4)
      for (std::size_t c = 0; c < ra.value()->cameras().size(); ++c) {
        auto x = ra.value()->raw_image(std::size_t(matched[i].first), c);
        auto y = rb.value()->raw_image(std::size_t(matched[i].second), c);
        if (!x || !y) continue;
        ++compared;
        identical += x.value().size() == y.value().size() && cv::norm(x.value(), y.value(), cv::NORM_INF) == 0;
      }
    std::printf("stored mosaics: %zu of %zu compared are bit-identical\n", identical, compared);
    EXPECT_GT(compared, 40u);
    EXPECT_EQ(identical, compared);
  }

  // The frames left at the recorded intervals (the replay's own log of when each left).
  CameraLogs cameras;
  for (const char* cam : {"cam0", "cam1", "cam2", "cam3"})
    EXPECT_GT(cameras.add(replayed / "sim-truth" / (std::string(cam) + "_replay.csv"), 1.0).sent.size(), 100u) << cam;
  const std::vector<double>& fill = cameras.fill;
  const std::string& late = cameras.late;
  const fs::path sensel_log = replayed / "sim-truth" / "sensel_replay.csv";
  const IntervalTiming sensel = sensel_timing(sensel_log);
  EXPECT_GT(sensel.sent.size(), 800u);
  std::printf("cameras: left after due and in the fill, p50 %.3f p95 %.3f max %.3f ms (%zu frames)\n", pct(fill, 0.5),
              pct(fill, 0.95), pct(fill, 1.0), fill.size());
  const auto sensel_own = sensel_own_delays_ms(sensel_log);
  std::printf("Sensel: left after the latest of due, asked and woke, p50 %.3f p95 %.3f max %.3f ms (%zu frames)\n",
              pct(sensel_own, 0.5), pct(sensel_own, 0.95), pct(sensel_own, 1.0), sensel_own.size());
  // Frames leave on time once started: the cameras' fill p95 0.11-0.24 ms, the Sensel's send p95
  // 0.045-0.072 ms beside the recorder on these 2 cores (docs/replay.md). The defects fixed on
  // 2026-11-26 spent their time there (each frame that brought a new image left 0.3-1.2 ms late).
  // How late the host started them is guarded, not bounded (expect_replay_timing). The kernel's
  // pseudo-terminal can hold a Sensel request back by tens of milliseconds on saturated cores; the
  // p95 does not reach it. The test runs alone (RUN_SERIAL).
  expect_replay_timing("cameras", cameras.timing, late);
  EXPECT_LT(pct(fill, 0.95), 0.5) << "intervals more than 1 ms off:" << late;
  const std::string sensel_late = late_sensel_frames(sensel_log, 1.0);
  expect_replay_timing("Sensel", sensel, sensel_late, LateStarts::Printed);
  EXPECT_LT(pct(sensel_own, 0.95), 0.5) << "intervals more than 1 ms off:" << sensel_late;
}

// A colour store keeps no mosaics: its images are sampled back into the camera's Bayer pattern and
// sent, so the re-recording shows the recorded scene (not grey frames), as close as the lossy video
// and a second demosaicing allow.
TEST(ReplayAsDevices, AColourStoreIsReServedAsItsImagesNotGrey) {
  const fs::path work = work_dir("replay-colour");
  std::string yaml = sim_rig_yaml({{}}, 640, 480, 30, 15);
  const std::string preset = "  preset: ultrafast\n";
  yaml.replace(yaml.find(preset), preset.size(), preset + "  video_mode: color\n");
  const RoundTrip trip = replay_and_record(work, {yaml, 3}, 3.5);
  ASSERT_FALSE(trip.replayed.empty());
  EXPECT_NE(trip.again_output.find("sampled back into BayerRG8"), std::string::npos) << trip.again_output;
  const fs::path &recorded = trip.recorded, &replayed = trip.replayed;

  // Samples found in both by the camera frame's device time: their images agree.
  const Recorded ra = read_recorded(recorded), rb = read_recorded(replayed);
  std::map<std::int64_t, std::int64_t> b_by_device;
  for (const auto& s : rb.samples)
    for (const auto& [name, frame] : s.cameras) b_by_device[frame.second] = s.index;
  auto a = SessionReader::open(recorded), b = SessionReader::open(replayed);
  ASSERT_TRUE(a && b);
  std::vector<double> differences;  // mean |again - then| per image (8-bit levels)
  double grey_difference = 0;       // what a grey frame would have differed by
  std::size_t without_camera = 0, not_again = 0, ties = 0, no_image_then = 0, no_image_again = 0;
  std::string missing;  // "index at t s" of each sample not found again, for a failure's message
  const std::int64_t shift = replay_shift(ra, rb);
  for (const auto& s : ra.samples) {
    if (s.cameras.empty()) {
      ++without_camera;
      continue;
    }
    const auto it = b_by_device.find(s.cameras.begin()->second.second);
    if (it == b_by_device.end()) {
      // Its tick may have taken the neighbouring frame again, at a tie (tick_decision).
      if (const auto d = tick_decision(ra, rb, shift, s); d && d->tie()) {
        ++ties;
        continue;
      }
      ++not_again;
      missing += fmt::format(" #{} at {:.3f} s", s.index, double(s.tick_ns - ra.samples.front().tick_ns) / 1e9);
      continue;
    }
    auto x = a.value()->image(std::size_t(s.index), 0), y = b.value()->image(std::size_t(it->second), 0);
    if (!x || x.value().empty()) {
      ++no_image_then;
      continue;
    }
    if (!y || y.value().empty()) {
      ++no_image_again;
      continue;
    }
    cv::Mat diff;
    cv::absdiff(x.value(), y.value(), diff);
    differences.push_back(cv::mean(diff)[0]);
    cv::absdiff(x.value(), cv::Scalar::all(128), diff);
    grey_difference = std::max(grey_difference, cv::mean(diff)[0]);
  }
  std::printf(
      "colour store: %zu samples recorded: %zu without a camera frame, %zu not sampled again (and %zu more whose "
      "tick took the neighbouring frame at a tie), %zu without an image then, %zu without an image again\n",
      ra.samples.size(), without_camera, not_again, ties, no_image_then, no_image_again);
  // ~45 samples, each found again with its image but for the replay's first moments (a frame due
  // before the camera streamed again is not sent). Under the suite's load only 14 once were: the
  // first 2 s of a recording were mapped by late arrivals until the latch probes spanned 2 s, which
  // moved a tick's pick to the frame a period away; a camera is now mapped by its first probe.
  EXPECT_LE(not_again, 2u) << "not found again:" << missing;
  ASSERT_GE(differences.size() + 2 + ties, ra.samples.size());
  ASSERT_GE(2 * differences.size(), ra.samples.size()) << "most samples compared image for image";
  std::sort(differences.begin(), differences.end());
  std::printf(
      "colour store re-served: %zu images compared; mean |again - then| median %.2f, worst %.2f levels "
      "(a grey frame: %.1f)\n",
      differences.size(), differences[differences.size() / 2], differences.back(), grey_difference);
  EXPECT_LT(differences.back(), 8.0);
  EXPECT_GT(grey_difference, 20.0) << "the scene is not grey: the comparison means something";
}

// A session recorded with hardware triggers replays with them: the printed rig keeps `trigger:
// hardware`, the replay's trigger line pulses as each recorded frame falls due, and the re-recording
// receives the same frames (ids and device times) at the recorded intervals.
TEST(ReplayAsDevices, AHardwareTriggeredSessionReplaysOnItsTriggerLine) {
  const fs::path work = work_dir("replay-hardware");
  const RoundTrip trip = replay_and_record(
      work, {sim_rig_yaml({{.drift_ppm = 40, .offset_ms = 5000}, {}}, 640, 480, 30, 15, "hardware"), 3}, 3.5);
  ASSERT_FALSE(trip.replayed.empty());
  std::stringstream printed;
  printed << std::ifstream(trip.replay_rig).rdbuf();
  EXPECT_NE(printed.str().find("trigger: hardware"), std::string::npos) << printed.str();
  EXPECT_EQ(trip.again_output.find("camera lost"), std::string::npos) << trip.again_output;
  EXPECT_EQ(trip.again_output.find("no trigger reaches it"), std::string::npos) << trip.again_output;
  const fs::path &recorded = trip.recorded, &replayed = trip.replayed;

  // Every camera frame recorded (after the replay's first moments) is received again, same id and
  // device time.
  const Recorded ra = read_recorded(recorded), rb = read_recorded(replayed);
  CameraLogs both;  // both cameras pooled, as the free-running test pools its four
  for (const char* cam : {"cam0", "cam1"}) {
    std::size_t recorded_frames = 0, again_frames = 0;
    for (const auto& [key, t] : ra.mapped_ns)
      if (key.first == cam) {
        ++recorded_frames;
        again_frames += rb.mapped_ns.count(key);
      }
    std::printf("%s: %zu of %zu recorded frames received again on the replay's trigger line\n", cam, again_frames,
                recorded_frames);
    EXPECT_GT(recorded_frames, 60u) << cam;
    EXPECT_GE(double(again_frames), 0.9 * double(recorded_frames)) << cam;
    ASSERT_GT(both.add(replayed / "sim-truth" / (std::string(cam) + "_replay.csv"), 0.5).sent.size(), 50u) << cam;
  }
  // A pulse 10 ms ahead of each frame, the engine woken as when free-running: what the replay
  // adds is bounded as then (expect_replay_timing). Both cameras fall due at one instant, so each
  // time the host is slow to wake an idle core their intervals move together (docs/replay.md, "The
  // trigger line and an idle core's wake"): the intervals as sent had p95 0.08-0.99 ms here in
  // fifteen runs, 1.94 and 6.06 ms in CI; their frames started late, and that is guarded only. A
  // trigger missed shows as a frame not received again. The time from the later of due and the
  // fill's start to the frame leaving was p95 0.075-0.127 ms in four runs, 0.28 ms in CI. The
  // defects fixed in sim/replay_camera.cpp spent their time there: each frame that brought a new
  // image left 0.3-1.2 ms late (the one before freed on the engine's thread), and on a trigger
  // line each camera waited for the other's copy.
  const std::vector<double>& fill = both.fill;
  const std::string& late = both.late;
  expect_replay_timing("both cameras", both.timing, late);
  std::printf("both cameras: left after due and in the fill, p50 %.3f p95 %.3f max %.3f ms (%zu frames)\n",
              pct(fill, 0.5), pct(fill, 0.95), pct(fill, 1.0), fill.size());
  EXPECT_LT(pct(fill, 0.95), 0.5) << "intervals more than 0.5 ms off:" << late;
}

// `--rate 2`: the same frames (ids, pixels, pressure) come twice as often, their device timestamps
// compressed so the device clocks still tick at their own rate; the printed command records for
// half the time.
TEST(ReplayAsDevices, AtRateTwoTheSameFramesComeTwiceAsOften) {
  const fs::path work = work_dir("replay-rate");
  const RoundTrip trip = replay_and_record(
      work, {sim_rig_yaml({{.drift_ppm = 40}}, 640, 480, 30, 15, "free-run", true), 5}, 3.1, "--rate 2");
  ASSERT_FALSE(trip.replayed.empty());
  EXPECT_GT(trip.printed_seconds, 2.5) << trip.rig_output;
  EXPECT_LT(trip.printed_seconds, 3.2);
  // The clocks tick as devices' do: the recorder sees no clock reset and no odd rate.
  EXPECT_EQ(trip.again_output.find("clock was reset"), std::string::npos) << trip.again_output;

  struct Frames {
    std::map<std::int64_t, std::int64_t> camera_device_ns;  // cam0: frame id -> device time
    std::vector<std::int64_t> camera_mapped_ns;
    std::map<int, std::vector<std::vector<std::uint8_t>>> pressure_by_counter;  // payloads, timestamp zeroed
    std::size_t pressure_frames = 0;
  };
  auto read = [](const fs::path& session) {
    sqlite::Database db(session / "session.db", sqlite::Database::Mode::ReadOnly);
    Frames f;
    auto c = db.prepare(
        "SELECT f.frame_id, f.device_ns, f.mapped_ns FROM frames f JOIN devices d ON d.id = f.device_id WHERE d.name "
        "= 'cam0' AND f.status = 'good' AND f.mapped_ns IS NOT NULL ORDER BY f.mapped_ns");
    while (c.step()) {
      f.camera_device_ns[c.column_int(0)] = c.column_int(1);
      f.camera_mapped_ns.push_back(c.column_int(2));
    }
    auto p = db.prepare("SELECT payload FROM pressure_frames");
    while (p.step()) {
      auto payload = p.column_blob(0);
      if (payload.size() < 6) continue;
      std::fill(payload.begin() + 2, payload.begin() + 6, 0);  // the device's timestamp
      f.pressure_by_counter[payload[1]].push_back(std::move(payload));
      ++f.pressure_frames;
    }
    return f;
  };
  const Frames a = read(trip.recorded), b = read(trip.replayed);

  // Every camera frame is received again with its id; its device time moved half as far from the
  // first frame's.
  std::size_t again = 0, halved = 0;
  const auto first_a = a.camera_device_ns.begin(), first_b = b.camera_device_ns.find(first_a->first);
  for (const auto& [id, device_ns] : a.camera_device_ns) {
    const auto it = b.camera_device_ns.find(id);
    if (it == b.camera_device_ns.end()) continue;
    ++again;
    if (first_b != b.camera_device_ns.end())
      halved += std::llabs((it->second - first_b->second) - (device_ns - first_a->second) / 2) < 2'000;
  }
  std::printf("cam0 at rate 2: %zu of %zu recorded frames received again, %zu at half the device time apart\n", again,
              a.camera_device_ns.size(), halved);
  EXPECT_GT(a.camera_device_ns.size(), 130u);
  EXPECT_GE(double(again), 0.9 * double(a.camera_device_ns.size()));
  EXPECT_EQ(halved, again);
  // The pressure frames come again with the same contents (all but the timestamp).
  std::size_t same = 0;
  for (const auto& [counter, payloads] : b.pressure_by_counter)
    for (const auto& payload : payloads) {
      const auto it = a.pressure_by_counter.find(counter);
      same += it != a.pressure_by_counter.end() &&
              std::find(it->second.begin(), it->second.end(), payload) != it->second.end();
    }
  std::printf("pressure at rate 2: %zu of %zu recorded frames received again, the same but for the timestamp\n", same,
              a.pressure_frames);
  EXPECT_GE(double(same), 0.9 * double(a.pressure_frames));
  // On the new session's clock the camera runs at 60 frames a second, and the frames left on time.
  ASSERT_GT(b.camera_mapped_ns.size(), 100u);
  const double fps =
      double(b.camera_mapped_ns.size() - 1) / (double(b.camera_mapped_ns.back() - b.camera_mapped_ns.front()) / 1e9);
  std::printf("re-recorded at rate 2: %.1f camera frames a second\n", fps);
  EXPECT_NEAR(fps, 60.0, 1.0);
  const fs::path cam_log = trip.replayed / "sim-truth" / "cam0_replay.csv";
  const fs::path sensel_log = trip.replayed / "sim-truth" / "sensel_replay.csv";
  expect_replay_timing("camera at rate 2", camera_timing(cam_log), late_camera_frames(cam_log, 1.0));
  expect_replay_timing("Sensel at rate 2", sensel_timing(sensel_log), late_sensel_frames(sensel_log, 1.0),
                       LateStarts::Printed);
}
