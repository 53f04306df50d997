// libFuzzer target: the timeline (sync::SessionTimeline: a clock model per stream, the grouper, the
// 15 Hz subsampler and the pressure aligner) fed adversarial device times. Device clocks are bytes
// from outside (a camera's timestamp, a Sensel's counter), so they may be anything: stuck, running
// backwards, jumping to either end of int64, restarting. Host arrivals are this machine's
// CLOCK_MONOTONIC, so they only move forward (by any amount). Whatever the device times:
//   - no undefined behaviour (UBSan: overflow in the arithmetic), no crash, no hang;
//   - every camera frame handed in gets exactly one decision by the end (kept, or why not);
//   - samples come out numbered 0, 1, 2... with their ticks rising, each group's frames within
//     the grouping limit of one another; a pressure pairing within the allowed offset.
#include <fuzzer/FuzzedDataProvider.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "sync/session_timeline.h"

namespace {

// A device counter wraps; it does not overflow.
std::int64_t wrapping_add(std::int64_t a, std::int64_t b) { return std::int64_t(std::uint64_t(a) + std::uint64_t(b)); }

std::int64_t next_device_time(FuzzedDataProvider& in, std::int64_t previous, std::int64_t period_ns) {
  switch (in.ConsumeIntegralInRange<int>(0, 7)) {
    case 0:
      return in.ConsumeIntegral<std::int64_t>();  // anything at all
    case 1:
      return wrapping_add(previous, in.ConsumeIntegralInRange<std::int64_t>(-4'000'000'000, 4'000'000'000));
    case 2:
      return in.PickValueInArray({std::numeric_limits<std::int64_t>::min(), std::numeric_limits<std::int64_t>::max(),
                                  std::int64_t(0), std::int64_t(-1), std::int64_t(1) << 62, -(std::int64_t(1) << 62)});
    default:  // a working clock, with jitter
      return wrapping_add(previous, period_ns + in.ConsumeIntegralInRange<std::int64_t>(-2'000'000, 2'000'000));
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  using namespace pvcap;
  sync::TimelineConfig config;
  config.cameras = in.ConsumeIntegralInRange<int>(1, 4);
  config.has_pressure = in.ConsumeBool();
  config.anchor_ns = 1'000'000'000;
  for (int c = 0; c < config.cameras; ++c)
    config.camera_latency_ns.push_back(in.ConsumeIntegralInRange<std::int64_t>(0, 50'000'000));
  config.pressure_latency_ns = in.ConsumeIntegralInRange<std::int64_t>(0, 50'000'000);
  const std::int64_t group_limit_ns = std::int64_t(0.5e9 / config.camera_hz);

  std::vector<sync::SampleOut> samples;
  sync::SessionTimeline timeline(
      config, [&](sync::SampleOut s) { samples.push_back(std::move(s)); }, [](sync::ClockSnapshot) {});

  std::int64_t host = config.anchor_ns;
  std::vector<std::int64_t> camera_device(std::size_t(config.cameras), 0);
  std::vector<std::uint64_t> camera_sequence(std::size_t(config.cameras), 0), handed(std::size_t(config.cameras), 0),
      decided(std::size_t(config.cameras), 0);
  std::int64_t pressure_device = 0;
  std::uint64_t pressure_sequence = 0;
  auto collect = [&] {
    for (int c = 0; c < config.cameras; ++c) decided[std::size_t(c)] += timeline.take_decisions(c).size();
  };
  for (int step = 0; step < 4000 && in.remaining_bytes() > 0; ++step) {
    host += in.ConsumeIntegralInRange<std::int64_t>(0, 40'000'000);  // CLOCK_MONOTONIC never goes back
    const int op = in.ConsumeIntegralInRange<int>(0, 9);
    if (op < 6) {
      const int c = in.ConsumeIntegralInRange<int>(0, config.cameras - 1);
      auto& device = camera_device[std::size_t(c)];
      device = next_device_time(in, device, 16'666'667);
      const std::uint32_t connection = in.ConsumeIntegralInRange<std::uint32_t>(0, 2);
      const std::uint64_t sequence =
          in.ConsumeBool() ? ++camera_sequence[std::size_t(c)] : in.ConsumeIntegral<std::uint64_t>();
      (void)timeline.camera_frame(c, connection, sequence, DeviceNs{device}, HostNs{host});
      ++handed[std::size_t(c)];
    } else if (op < 8) {
      pressure_device = next_device_time(in, pressure_device, 8'700'000);
      (void)timeline.pressure_frame(in.ConsumeIntegralInRange<std::uint32_t>(0, 2), ++pressure_sequence,
                                    DeviceNs{pressure_device}, HostNs{host});
    } else if (op == 8) {
      const int c = in.ConsumeIntegralInRange<int>(0, config.cameras - 1);
      const std::int64_t width = in.ConsumeIntegralInRange<std::int64_t>(0, 5'000'000);
      timeline.camera_probe(c, DeviceNs{next_device_time(in, camera_device[std::size_t(c)], 0)}, HostNs{host},
                            HostNs{host + width});
      host += width;
    } else {
      collect();
    }
  }
  timeline.flush();
  collect();
  timeline.final_snapshots();
  (void)timeline.counts();

  for (int c = 0; c < config.cameras; ++c)
    if (decided[std::size_t(c)] != handed[std::size_t(c)]) __builtin_trap();  // one decision per frame
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const auto& s = samples[i];
    if (s.index != i) __builtin_trap();
    if (i > 0 && s.tick <= samples[i - 1].tick) __builtin_trap();
    std::int64_t lo = std::numeric_limits<std::int64_t>::max(), hi = std::numeric_limits<std::int64_t>::min();
    for (const auto& m : s.group.members) {
      if (!m) continue;
      lo = std::min(lo, m->t_ns);
      hi = std::max(hi, m->t_ns);
    }
    if (lo <= hi && hi - lo > 2 * group_limit_ns) __builtin_trap();
    if (s.pressure.nearest &&
        (s.pressure.offset_ns > config.pressure_max_offset_ns || s.pressure.offset_ns < -config.pressure_max_offset_ns))
      __builtin_trap();
  }
  return 0;
}
