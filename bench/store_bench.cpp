// Store benchmark, printed in one run for the default mode (raw: the sensor's mosaic, lossless) and
// the lossy colour mode (figures in docs/performance-log.md):
//  1. pipeline fps, one 1080p camera: (debayer +) encode + index through SessionWriter, against the
//     ffmpeg command line encoding the same frames with the same settings (ratio; goal >= 1);
//  2. real-time factor for four 1080p cameras at 15 Hz (goal >= 1.5): the fastest pace, as a multiple of
//     real time, at which the store keeps every frame under its own rules (memory and spill age limits);
//     raw mode also at 60 Hz with every frame stored ("full rate", goal >= 1.0); and the encoders' own
//     throughput fed at full speed, beside four ffmpeg command lines;
//  3. random access: one camera image of a random sample, demosaiced (goal < 30 ms);
//  4. sequential reading: samples (all cameras decoded) per second;
//  5. exactness: raw mode, the stored mosaic against the sensor's ("bit-exact"); colour mode, PSNR of
//     the decoded images against their debayered sources;
//  6. raw mode: `pvcap compact` on the finished store, bytes per frame before and after, its speed,
//     and the mosaics read back again.
// The speed figures come with the same measure for the ffmpeg command line, run in the same run.
// Usage: store_bench [FRAMES=90] [NOISE_DN=2] ["STORE SETTINGS" for both modes, e.g. "crf: 16"] [short|raw|quick]
// (`short`: the suite's short form, see short_form below; `raw`: the raw default alone, without the
// lossy colour mode's figures, as bench/goals.sh reads them; `quick`: raw alone in a few seconds, for
// goals.sh --short)
// Frames are the simulator's scene with a moving fingertip and sensor noise, prepared beforehand.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <thread>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>
#include <opencv2/core.hpp>

#include "bench/bench_mosaics.h"
#include "codec/pixel_format.h"
#include "core/frame_pool.h"
#include "core/rig_config.h"
#include "core/statistics.h"
#include "core/time.h"
#include "storage/index/session_reader.h"
#include "storage/tools/compact.h"
#include "storage/video/bayer_planes.h"
#include "storage/video/view_video.h"
#include "storage/writer/session_writer.h"

namespace fs = std::filesystem;
using namespace pvcap;
using Clock = std::chrono::steady_clock;

namespace {
constexpr int kW = bench::kMosaicWidth, kH = bench::kMosaicHeight;
const std::uint32_t kBayer = pixel_format_code("BayerRG8");

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

std::vector<cv::Mat> make_frames(int cam, int n, double noise) { return bench::make_mosaics(cam, n, noise); }

// `store_fields`: rig-file store settings to try instead of pvcap's defaults ("gop_seconds: 0.5, crf: 14").
RigConfig bench_rig(int cameras, const std::string& store_fields) {
  std::string y = "name: store-bench\ncameras:\n";
  for (int c = 0; c < cameras; ++c) y += fmt::format("  - {{name: cam{}, address: 10.0.0.{}}}\n", c, c + 1);
  y += fmt::format("store: {{min_free_mb: 0, reserve_mb: 0{}{}}}\n", store_fields.empty() ? "" : ", ", store_fields);
  return parse_rig_config(y, "store-bench.yaml");
}

// How a run feeds the store. Full speed (pace 0): each camera's frames as fast as its encoder takes
// them, waiting while its queue is full (the encoder alone, never the spill). Paced: the cameras'
// frames at `rate_hz` times `pace` on the wall clock, as cameras running that much faster than real
// time would deliver them, `repeat` times over (a longer run from the same frames), never waiting on
// the store: what it cannot keep under its own rules (the memory-age and spill-age limits) it refuses,
// and the run counts those frames.
struct Feed {
  double pace = 0;
  double rate_hz = 15;
  int repeat = 1;
};
struct FeedResult {
  double seconds = 0;
  std::uint64_t submitted = 0, refused = 0;
  std::uint64_t spilled = 0;  // frames that waited in the spill on disk: the encoders fell behind
};

// Feeds every camera's frames (each camera on its own thread, as the recorder's camera workers do:
// copy or debayer, then hand to the encoder).
FeedResult run_pipeline(const fs::path& root, const std::vector<std::vector<cv::Mat>>& frames,
                        const std::string& fields, fs::path* session, const Feed& feed = {}) {
  const RigConfig rig = bench_rig(int(frames.size()), fields);
  const std::int64_t t0 = host_now().ns;
  auto w = SessionWriter::create(root, rig, wall_now_ns(), t0);
  if (!w) throw std::runtime_error(w.error().message);
  SessionWriter& writer = *w.value();
  std::vector<std::int64_t> ids;
  for (const auto& c : rig.cameras)
    ids.push_back(writer.add_camera({"camera", c.name, "", "", "", "", "", "{}"}, kW, kH, "BayerRG8").value());
  writer.start();
  const auto start = Clock::now();
  const auto period = std::chrono::nanoseconds(std::int64_t(1e9 / feed.rate_hz));
  std::atomic<std::uint64_t> submitted{0}, refused{0};
  std::vector<std::thread> feeders;
  for (std::size_t c = 0; c < frames.size(); ++c)
    feeders.emplace_back([&, c] {
      FramePool images(std::size_t(rig.store.queue_frames) + 2);  // as the recorder's camera workers do
      const bool raw = writer.stores_raw(ids[c]);
      const std::size_t n = frames[c].size() * std::size_t(std::max(1, feed.repeat));
      for (std::size_t i = 0; i < n; ++i) {
        const cv::Mat& source = frames[c][i % frames[c].size()];
        if (feed.pace > 0)
          std::this_thread::sleep_until(start +
                                        std::chrono::duration_cast<Clock::duration>(period * double(i) / feed.pace));
        cv::Mat image = images.acquire(kH, kW, raw ? CV_8UC1 : CV_8UC3);
        if (raw)
          source.copyTo(image);  // the mosaic, as the camera worker copies it
        else
          (void)to_bgr(source.data, source.total(), kW, kH, kBayer, image);
        // Its arrival is now, as a camera's frame arrives: the store's age rules and its disk-age
        // warning measure from it.
        const std::int64_t t = host_now().ns;
        FrameRecord f{ids[c], 0, i, i, std::int64_t(i), t, 0, "good", false, "", {}, {}, t};
        if (feed.pace <= 0)
          // Full speed, but through memory only, and never long there: two frames waiting at most (the
          // store's memory-age rule sends a frame waiting 200 ms to the spill, and a queue of 24
          // 1080p frames on two busy cores waited longer: the spill, then refusals, were measured).
          while (writer.camera_stats(ids[c]).encoder_backlog >= 2)
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
        submitted.fetch_add(1);
        if (!writer.submit_video(ids[c], image, f)) {
          refused.fetch_add(1);
          continue;
        }
        if (c != 0) continue;  // one sample per instant, naming every camera's frame of it
        SampleRecord sample{i, std::int64_t(i), t, t, 0, {}, {}, {}, {}};
        for (const std::int64_t id : ids) sample.cameras.push_back({id, 0, i, 0});
        writer.record(std::move(sample));
      }
    });
  for (auto& t : feeders) t.join();
  std::uint64_t spilled = 0;
  for (const std::int64_t id : ids) spilled += writer.camera_stats(id).spilled;
  const Status closed = writer.close("bench");
  const double s = seconds_since(start);
  if (!closed.ok()) throw std::runtime_error(closed.error().message);
  if (session) *session = writer.dir();
  return {s, submitted.load(), refused.load(), spilled};
}

// The fastest pace, as a multiple of real time, at which the store keeps every frame of the four
// cameras at `rate_hz` under its own rules, and keeps up: no frame refused and none left to wait in
// the spill (the spill on disk absorbs a burst, so a short run faster than the encoders would still
// keep everything; a session that long would not). Paces tried upwards until one fails.
struct Sustained {
  double pace = 0;            // the fastest that kept every frame (0: not even the first)
  std::uint64_t refused = 0;  // frames the last pace tried refused
  std::string per_pace;       // each pace tried: "1.0x kept", "2.0x refused 12 of 360"
};
Sustained sustained_pace(const fs::path& dir, const std::vector<std::vector<cv::Mat>>& frames,
                         const std::string& fields, double rate_hz, int repeat,
                         const std::vector<double>& paces = {0.5, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 6.0}) {
  Sustained out;
  for (const double pace : paces) {
    const fs::path root = dir / fmt::format("paced-{:.0f}-{:.2f}", rate_hz, pace);
    const FeedResult r = run_pipeline(root, frames, fields, nullptr, {pace, rate_hz, repeat});
    std::error_code ec;
    fs::remove_all(root, ec);
    out.per_pace += fmt::format("{}{:.2f}x {}", out.per_pace.empty() ? "" : ", ", pace,
                                r.refused > 0   ? fmt::format("refused {} of {}", r.refused, r.submitted)
                                : r.spilled > 0 ? fmt::format("kept all, {} through the spill", r.spilled)
                                                : "kept all in memory");
    out.refused = r.refused;
    if (r.refused > 0 || r.spilled > 0) break;
    out.pace = pace;
  }
  return out;
}

// 6. Raw mode: `pvcap compact` on the finished store (its defaults), then camera 0's mosaics read back
// against the sensor's again.
void bench_compact(const fs::path& session, const std::vector<cv::Mat>& sensor, int n, double noise, int reads = 60) {
  CompactOptions o;
  const auto t = Clock::now();
  auto c = compact_session(session, o);
  const double s = seconds_since(t);
  if (!c) throw std::runtime_error("compact: " + c.error().message);
  const auto& rep = c.value();
  auto reader = SessionReader::open(session);
  if (!reader) throw std::runtime_error("cannot read the compacted store: " + reader.error().message);
  std::mt19937 rng(11);
  std::vector<double> ms;
  for (int k = 0; k < reads; ++k) {
    const std::size_t i = rng() % reader.value()->sample_count(), cam = rng() % reader.value()->cameras().size();
    const auto t_read = Clock::now();
    auto img = reader.value()->image(i, cam);
    ms.push_back(seconds_since(t_read) * 1e3);
    if (!img || img.value().empty()) std::printf("compacted: sample %zu camera %zu did not read\n", i, cam);
  }
  std::size_t exact = 0;
  for (std::size_t i = 0; i < reader.value()->sample_count() && i < sensor.size(); ++i) {
    auto m = reader.value()->raw_image(i, 0);
    exact += m && !m.value().empty() && cv::norm(m.value(), sensor[i], cv::NORM_INF) == 0;
  }
  const double frames = double(std::max<std::int64_t>(1, rep.frames));
  std::printf(
      "compact (%s qp 0, preset %s, gop %d, %d threads): %.2f -> %.2f MB per 1080p frame (%.0f %%), %lld frames in "
      "%.1f s = %.1f frames/s; camera 0 read back: %s (%zu of %zu mosaics equal the sensor's)\n",
      o.codec.c_str(), o.preset.c_str(), o.gop_frames, o.threads, double(rep.bytes_before) / 1e6 / frames,
      double(rep.bytes_after) / 1e6 / frames,
      100.0 * double(rep.bytes_after) / double(std::max<std::uint64_t>(1, rep.bytes_before)),
      static_cast<long long>(rep.frames), s, frames / s, exact == sensor.size() ? "bit-exact" : "NOT exact", exact,
      sensor.size());
  std::printf("compacted: random access, one camera image of a random sample: p50 %.1f ms, p95 %.1f ms, max %.1f ms\n",
              percentile(ms, 0.5), percentile(ms, 0.95), percentile(ms, 1.0));
  if (noise <= 0) return;
  // The floor under compact and any other lossless coder on these frames: their noise's entropy.
  double floor_bytes = 0;
  for (int c = 0; c < 4; ++c)
    for (const cv::Mat& clean : make_frames(c, n, 0)) floor_bytes += bench::noise_bound_bytes(clean, noise);
  std::printf(
      "compact's floor: the noise's own entropy given the clean mosaics, %.3f MB per 1080p frame (no lossless coder "
      "averages less)\n",
      floor_bytes / 1e6 / (4.0 * n));
}

// The suite's short form (`store_bench 15 2 "" short`, ctest bench.store_short): raw mode only, on
// few frames, beside the other tests: the store keeps every frame fed at real time at 15 Hz and at a
// quarter of 60 Hz with every frame stored, reads back bit-exact and at random. Exit 1 if it does not:
// a change that breaks the store or this bench fails the suite. No speed is judged here.
int short_form(const fs::path& work, const std::vector<std::vector<cv::Mat>>& frames) {
  const std::string raw = "video_mode: raw";
  int failures = 0;
  const Sustained at15 = sustained_pace(work, frames, raw, 15, 1, {1.0});
  const Sustained at60 = sustained_pace(work, frames, raw + ", video_fps: 0", 60, 1, {0.25});
  std::printf("short form: 4 x 1080p at 15 Hz, real time: %s; at 60 Hz every frame, a quarter of real time: %s\n",
              at15.per_pace.c_str(), at60.per_pace.c_str());
  // A frame refused fails; one that waited in the spill (a loaded suite) does not.
  failures += at15.refused > 0;
  failures += at60.refused > 0;
  fs::path session;
  (void)run_pipeline(work / "short", frames, raw, &session);
  auto reader = SessionReader::open(session);
  if (!reader) {
    std::printf("short form: the store does not read back: %s\n", reader.error().message.c_str());
    return 1;
  }
  std::size_t exact = 0, read = 0;
  for (std::size_t i = 0; i < reader.value()->sample_count() && i < frames[0].size(); ++i) {
    auto m = reader.value()->raw_image(i, 0);
    exact += m && !m.value().empty() && cv::norm(m.value(), frames[0][i], cv::NORM_INF) == 0;
    auto img = reader.value()->image(reader.value()->sample_count() - 1 - i, i % 4);
    read += img && !img.value().empty();
  }
  std::printf("short form: %zu of %zu mosaics of camera 0 bit-exact; %zu of %zu images read back at random\n", exact,
              frames[0].size(), read, frames[0].size());
  failures += exact != frames[0].size() || read != frames[0].size();
  std::printf("short form: %s\n", failures ? "FAILED" : "passed");
  return failures ? 1 : 0;
}

// Steps 1-5 for one mode (`fields`: the store settings of the mode), printed with `label`.
// `quick` (goals.sh --short): one pace at each rate, no reference command lines, no durability
// rounds: figures to check that the bench runs, not to quote.
void bench_mode(const std::string& label, const fs::path& work, const std::vector<std::vector<cv::Mat>>& frames,
                const std::string& fields, double noise, bool quick = false) {
  const StoreConfig store = bench_rig(1, fields).store;
  const bool raw = store.video_mode == "raw";
  const int n = int(frames[0].size());
  if (raw)
    std::printf("\n[%s] raw: the mosaic's four planes stacked (960x2160 grey), %s, lossless, intra-only\n",
                label.c_str(), store.raw_codec.c_str());
  else
    std::printf("\n[%s] colour: debayered, %s crf %d %s %s, GOP %.1f s\n", label.c_str(), store.video_codec.c_str(),
                store.crf, store.preset.c_str(), store.video_pixel_format.c_str(), store.gop_seconds_x10 / 10.0);
  const fs::path dir = work / label;
  fs::create_directories(dir);

  // 1. One camera: pvcap's pipeline against the ffmpeg command line on the same frames.
  const FeedResult one_run = quick ? FeedResult{} : run_pipeline(dir / "one", {frames[0]}, fields, nullptr);
  const double one = one_run.seconds;
  if (one_run.refused)
    std::printf("  (1 camera at full speed: the store refused %llu of %llu frames)\n",
                static_cast<unsigned long long>(one_run.refused), static_cast<unsigned long long>(one_run.submitted));
  const double pipeline_fps = n / one;
  // The reference: ffmpeg encoding camera `c`'s frames with the same settings, one thread each (raw
  // mode: given the planes already stacked, so ffmpeg does less than the pipeline).
  auto ffmpeg_cmd = [&](int c) {
    const fs::path raw_path = dir / fmt::format("cam{}.{}", c, raw ? "planes" : "bayer");
    std::ofstream out(raw_path, std::ios::binary);
    for (const auto& f : frames[std::size_t(c)]) {
      cv::Mat data = f;
      if (raw) pack_bayer_planes(f, data);
      out.write(reinterpret_cast<const char*>(data.data), std::streamsize(data.total()));
    }
    const std::string output = (dir / fmt::format("ffmpeg{}.mkv", c)).string();
    if (raw) {
      const std::string x264 = store.raw_codec == "libx264" ? " -preset " + store.preset + " -qp 0" : "";
      return fmt::format(
          "ffmpeg -hide_banner -loglevel error -y -f rawvideo -pix_fmt gray -s {}x{} -framerate 15 "
          "-i {} -c:v {}{} -pix_fmt gray -threads 1 {}",
          kW / 2, kH * 2, raw_path.string(), store.raw_codec, x264, output);
    }
    return fmt::format(
        "ffmpeg -hide_banner -loglevel error -y -f rawvideo -pix_fmt bayer_rggb8 -s {}x{} -framerate 15 -i {} "
        "-c:v libx264 -preset {} -crf {} -pix_fmt {} -g {} -bf 0 -threads 1 -x264-params repeat-headers=1:slices=4 "
        "{}",
        kW, kH, raw_path.string(), store.preset, store.crf, store.video_pixel_format,
        int(15 * store.gop_seconds_x10 / 10), output);
  };
  auto run_timed = [&](const std::string& cmd) {
    const auto t = Clock::now();
    const int rc = std::system(cmd.c_str());
    if (rc != 0) std::printf("ffmpeg command line failed (%d): %s\n", rc, cmd.c_str());
    return seconds_since(t);
  };
  const double ffmpeg_fps = quick ? 0 : n / run_timed(ffmpeg_cmd(0));
  if (!quick)
    std::printf(
      "pipeline, 1 camera (%s + index): %.1f fps; ffmpeg command line, same frames and settings: %.1f fps; "
      "ratio %.2f (goal >= 1.0)\n",
      raw ? "plane split + encode" : "debayer + encode", pipeline_fps, ffmpeg_fps, pipeline_fps / ffmpeg_fps);

  // 2. Four cameras at once, under the store's own rules: the fastest pace (a multiple of real time)
  // at which it keeps every frame, at 15 Hz (one frame of each camera per sample) and at 60 Hz with
  // every frame stored; beside them, four ffmpeg command lines run side by side (what the machine
  // allows at these settings), and the encoders' own throughput fed at full speed.
  const Sustained at15 = quick ? sustained_pace(dir, frames, fields, 15, 1, {1.0})
                               : sustained_pace(dir, frames, fields, 15, 1);
  std::printf(
      "pipeline, 4 cameras: real-time factor %.2f for 4 x 1080p at 15 Hz, every frame kept and the encoders keeping up "
      "(goal >= 1.5; %s)\n",
      at15.pace, at15.per_pace.c_str());
  fs::path session;
  const FeedResult four_run = run_pipeline(dir / "four", frames, fields, &session);
  const double four = four_run.seconds;
  if (four_run.refused)
    std::printf("  (4 cameras at full speed: the store refused %llu of %llu frames)\n",
                static_cast<unsigned long long>(four_run.refused), static_cast<unsigned long long>(four_run.submitted));
  const double four_fps = 4.0 * n / four;
  std::string all = "(";
  for (int c = 0; c < 4; ++c) all += ffmpeg_cmd(c) + " & ";
  all += "wait)";
  const double ffmpeg_four_fps = quick ? 0 : 4.0 * n / run_timed(all);
  if (!quick)
    std::printf(
      "  encoders at full speed: %.1f frames/s in all = %.2f x (4 x 15 Hz); 4 ffmpeg command lines at once: %.2f x; "
      "ratio %.2f\n",
      four_fps, four_fps / 60.0, ffmpeg_four_fps / 60.0, four_fps / ffmpeg_four_fps);
  if (raw) {
    const std::string every = fields.empty() ? "video_fps: 0" : fields + ", video_fps: 0";
    const Sustained at60 = quick ? sustained_pace(dir, frames, every, 60, 4, {0.5})
                                 : sustained_pace(dir, frames, every, 60, 4);
    std::printf(
        "full rate: real-time factor %.2f for 4 x 1080p at 60 Hz, every frame stored (goal >= 1.0; %s); the encoders "
        "at full speed reach %.2f x of it\n",
        at60.pace, at60.per_pace.c_str(), four_fps / 240.0);
  }

  // The durability horizon's cost: the same four cameras with the fsyncs on (the default) and off
  // (store.sync_interval_s: 0), alternated three times in the same run, medians compared (one
  // short run of each differs by +-10 % here from the machine alone).
  if (!quick) {
    const std::string no_sync = fields.empty() ? "sync_interval_s: 0" : fields + ", sync_interval_s: 0";
    std::vector<double> with, without;
    for (int round = 0; round < 3; ++round) {
      with.push_back(4.0 * n / run_pipeline(dir / fmt::format("sync-{}", round), frames, fields, nullptr).seconds /
                     60.0);
      without.push_back(4.0 * n /
                        run_pipeline(dir / fmt::format("nosync-{}", round), frames, no_sync, nullptr).seconds / 60.0);
      std::error_code ec;
      fs::remove_all(dir / fmt::format("sync-{}", round), ec);
      fs::remove_all(dir / fmt::format("nosync-{}", round), ec);
    }
    const double w = percentile(with, 0.5), wo = percentile(without, 0.5);
    std::printf(
        "durability: 4 cameras, every file fsynced each second: real-time factor %.2f (median of %s); "
        "without the fsyncs: %.2f (%s); the fsyncs cost %.1f %% (goal < 5 %%)\n",
        w, fmt::format("{:.2f}", fmt::join(with, " ")).c_str(), wo,
        fmt::format("{:.2f}", fmt::join(without, " ")).c_str(), 100.0 * (1.0 - w / wo));
  }

  // 3. Random access and 4. sequential reading, on the four-camera store.
  auto reader = SessionReader::open(session);
  if (!reader) throw std::runtime_error("cannot read the store back: " + reader.error().message);
  auto& r = *reader.value();
  std::mt19937 rng(7);
  std::vector<double> ms;
  for (int k = 0; k < 60; ++k) {
    const std::size_t i = rng() % r.sample_count(), c = rng() % r.cameras().size();
    const auto t = Clock::now();
    auto img = r.image(i, c);
    ms.push_back(seconds_since(t) * 1e3);
    if (!img || img.value().empty()) std::printf("sample %zu camera %zu did not read\n", i, c);
  }
  std::printf(
      "random access, one camera image of a random sample%s: p50 %.1f ms, p95 %.1f ms, max %.1f ms (goal < "
      "30 ms)\n",
      raw ? " (decoded and demosaiced)" : "", percentile(ms, 0.5), percentile(ms, 0.95), percentile(ms, 1.0));
  const auto t_seq = Clock::now();
  for (std::size_t i = 0; i < r.sample_count(); ++i)
    if (!r.sample(i)) std::printf("sample %zu did not read\n", i);
  const double seq_s = seconds_since(t_seq);
  std::printf("sequential reading: %.1f samples/s (%.1f decoded 1080p frames/s)\n", double(r.sample_count()) / seq_s,
              double(r.sample_count() * r.cameras().size()) / seq_s);
  // 5. Exactness: raw mode, every stored mosaic of camera 0 against the sensor's; colour mode, the
  // decoded images against the debayered frames they were made from (and, with noise, against the
  // noise-free scene: what the encoder kept of the picture itself).
  if (raw) {
    double worst = 0;
    std::size_t compared = 0;
    for (std::size_t i = 0; i < r.sample_count() && i < frames[0].size(); ++i) {
      auto m = r.raw_image(i, 0);
      if (!m || m.value().empty()) continue;
      worst = std::max(worst, cv::norm(m.value(), frames[0][i], cv::NORM_INF));
      ++compared;
    }
    if (worst == 0 && compared == frames[0].size())
      std::printf("exactness, camera 0: bit-exact (%zu of %zu stored mosaics equal the sensor's)\n", compared,
                  frames[0].size());
    else
      std::printf("exactness, camera 0: NOT exact: largest difference %.0f DN over %zu of %zu frames\n", worst,
                  compared, frames[0].size());
  } else {
    const std::vector<cv::Mat> clean = noise > 0 ? make_frames(0, n, 0) : std::vector<cv::Mat>{};
    double worst = 1e9, sum = 0, worst_clean = 1e9;
    for (std::size_t i = 0; i < r.sample_count() && i < frames[0].size(); ++i) {
      auto img = r.image(i, 0);
      if (!img || img.value().empty()) continue;
      cv::Mat source;
      (void)to_bgr(frames[0][i].data, frames[0][i].total(), kW, kH, kBayer, source);
      const double psnr = cv::PSNR(img.value(), source);
      worst = std::min(worst, psnr);
      sum += psnr;
      if (!clean.empty()) {
        (void)to_bgr(clean[i].data, clean[i].total(), kW, kH, kBayer, source);
        worst_clean = std::min(worst_clean, cv::PSNR(img.value(), source));
      }
    }
    std::printf(
        "exactness, camera 0: lossy, worst frame PSNR %.1f dB, mean %.1f dB against the debayered source "
        "(goal >= 45)",
        worst, sum / double(std::min(r.sample_count(), frames[0].size())));
    if (!clean.empty()) std::printf("; worst %.1f dB against the noise-free scene", worst_clean);
    std::printf("\n");
  }
  std::uintmax_t bytes = 0, view_bytes = 0;
  for (const auto& e : fs::recursive_directory_iterator(session))
    if (e.is_regular_file()) (e.path().parent_path().filename() == kViewFolder ? view_bytes : bytes) += e.file_size();
  std::printf(
      "store size: %.1f MB for %d samples of 4 cameras (%.2f MB per 1080p frame), and %.1f MB of view videos "
      "(%.3f MB per frame)\n",
      double(bytes) / 1e6, n, double(bytes) / 1e6 / (4.0 * n), double(view_bytes) / 1e6,
      double(view_bytes) / 1e6 / (4.0 * n));
  if (raw) bench_compact(session, frames[0], n, noise, quick ? 10 : 60);
}
}  // namespace

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::max(15, std::atoi(argv[1])) : 90;              // frames per camera (90 = 6 s at 15 Hz)
  const double noise = argc > 2 ? std::atof(argv[2]) : bench::kSensorNoiseDn;  // sensor noise, DN
  const fs::path work = fs::temp_directory_path() / fmt::format("pvcap-store-bench-{}", getpid());
  fs::remove_all(work);
  fs::create_directories(work);
  spdlog::set_level(spdlog::level::warn);              // the writer's progress lines would interleave with the figures
  const std::string fields = argc > 3 ? argv[3] : "";  // store settings other than the defaults
  auto with = [&](const std::string& mode) { return fields.empty() ? mode : mode + ", " + fields; };
  try {
    (void)bench_rig(1, fields);
  } catch (const std::exception& e) {
    std::printf("%s\n", e.what());
    return 2;
  }
  std::printf("store bench: %d frames per camera, 1920x1080 BayerRG8 with sensor noise %.1f DN, %u cores\n", n, noise,
              std::thread::hardware_concurrency());
  std::vector<std::vector<cv::Mat>> frames;
  for (int c = 0; c < 4; ++c) frames.push_back(make_frames(c, n, noise));
  if (argc > 4 && std::string(argv[4]) == "short") {
    int rc = 1;
    try {
      rc = short_form(work, frames);
    } catch (const std::exception& e) {
      std::printf("short form: %s\n", e.what());
    }
    fs::remove_all(work);
    return rc;
  }
  try {
    const std::string only = argc > 4 ? argv[4] : "";
    bench_mode("default", work, frames, with("video_mode: raw"), noise, only == "quick");
    if (only.empty()) bench_mode("lossy", work, frames, with("video_mode: color"), noise);
  } catch (const std::exception& e) {
    std::printf("%s\n", e.what());
    return 1;
  }
  if (!std::getenv("PVCAP_BENCH_KEEP"))
    fs::remove_all(work);
  else
    std::printf("kept %s\n", work.c_str());
  return 0;
}
