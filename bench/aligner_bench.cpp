// Timeline throughput and memory, single core, no I/O: pressure frames/s through the
// clock model + pressure aligner (the target: >= 1e6 per core), the same for
// camera frames through clock model + grouper + subsampler, and the aligner's buffer
// after a minute and after an hour of recording (bounded by its window, not the
// session). Reference in the same run: the cost of generating the synthetic stream
// alone, so the figures are the timeline's own.
#include <chrono>
#include <cstdio>
#include <random>

#include "sync/clock_model.h"
#include "sync/timeline.h"

using namespace pvcap::sync;
using Clock = std::chrono::steady_clock;

namespace {

struct Synthetic {
  std::mt19937_64 rng{42};
  std::exponential_distribution<double> jitter{1.0 / 1e6};                              // 1 ms mean USB delay
  std::int64_t device(std::int64_t t) const { return 5'000'000'000 + t + t / 20'000; }  // +50 ppm
  std::int64_t arrival(std::int64_t t) { return t + 300'000 + std::int64_t(std::min(jitter(rng), 4e6)); }
};

struct Result {
  double seconds = 0;
  std::size_t max_buffered = 0;
  std::uint64_t paired = 0;
};

// Pressure at 125 Hz and samples at 15 Hz for `session_s` seconds of recording.
Result run_pressure(double session_s, bool with_timeline) {
  Synthetic syn;
  ClockModel model;
  PressureAligner aligner(60'000'000, 20'000'000);
  Result r;
  const auto n = std::int64_t(session_s * 125);
  std::int64_t next_sample = 0, key = 0;
  std::int64_t sink = 0;
  const auto t0 = Clock::now();
  for (std::int64_t i = 0; i < n; ++i) {
    const std::int64_t t = i * 8'000'000;
    const std::int64_t dev = syn.device(t), arr = syn.arrival(t);
    if (!with_timeline) {
      sink += dev ^ arr;
      continue;
    }
    model.add(dev, arr);
    aligner.add_pressure({0, std::uint64_t(i), model.map(dev)});
    // Samples reach the aligner ~300 ms behind the pressure stream, as in a recording.
    while (next_sample * 66'666'667 + 300'000'000 < t)
      aligner.add_sample(next_sample++ * 66'666'667, std::uint64_t(key++));
    for (auto& p : aligner.take()) r.paired += p.second.nearest ? 1 : 0;
    r.max_buffered = std::max(r.max_buffered, aligner.buffered());
  }
  r.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  if (sink == 42) std::puts("");
  return r;
}

// Four cameras at 60 Hz through clock models, the grouper and the 15 Hz subsampler.
Result run_cameras(double session_s) {
  Synthetic syn;
  std::vector<ClockModel> models(4);
  Grouper grouper(4, 8'333'333, 250'000'000);
  Subsampler sub(0, 15.0);
  Result r;
  const auto n = std::int64_t(session_s * 60);
  const auto t0 = Clock::now();
  for (std::int64_t i = 0; i < n; ++i)
    for (int c = 0; c < 4; ++c) {
      const std::int64_t t = i * 16'666'667 + std::int64_t(c) * 500'000;
      const std::int64_t dev = syn.device(t) + std::int64_t(c) * 1'000'000'000;
      models[std::size_t(c)].add(dev, syn.arrival(t));
      grouper.add({c, std::uint64_t(i), models[std::size_t(c)].map(dev)});
      for (const auto& g : grouper.take()) r.paired += sub.add(g).size();
    }
  r.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return r;
}

}  // namespace

int main() {
  const double session_s = 3600;  // one hour of recording
  const Result bare = run_pressure(session_s, false);
  const Result pressure = run_pressure(session_s, true);
  const double frames = session_s * 125;
  std::printf("aligner_bench: synthetic streams, 1 core, no I/O\n");
  std::printf(
      "  pressure: clock model + aligner: %.0f frames/s (%.0f ns/frame; generating the stream alone: %.0f ns/frame); "
      "%llu samples paired\n",
      frames / (pressure.seconds - bare.seconds), (pressure.seconds - bare.seconds) / frames * 1e9,
      bare.seconds / frames * 1e9, static_cast<unsigned long long>(pressure.paired));
  const Result minute = run_pressure(60, true);
  std::printf(
      "  aligner buffer: at most %zu frames (%zu bytes) over 1 min, %zu frames (%zu bytes) over 1 h: "
      "bounded by the window, not the session\n",
      minute.max_buffered, minute.max_buffered * sizeof(FrameRef), pressure.max_buffered,
      pressure.max_buffered * sizeof(FrameRef));
  const Result cams = run_cameras(session_s);
  const double cam_frames = session_s * 60 * 4;
  std::printf("  cameras: 4 clock models + grouper + subsampler: %.0f frames/s (%.0f ns/frame), %llu samples\n",
              cam_frames / cams.seconds, cams.seconds / cam_frames * 1e9, static_cast<unsigned long long>(cams.paired));
  std::printf("  a recording needs ~125 pressure + 240 camera frames/s: %.0fx headroom\n",
              std::min(frames / (pressure.seconds - bare.seconds) / 125, cam_frames / cams.seconds / 240));
  return 0;
}
