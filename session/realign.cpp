#include "session/realign.h"

#include <algorithm>
#include <climits>
#include <map>
#include <tuple>

namespace pvcap {

RealignResult realign(SessionIndex& index, const RealignInput& in) {
  using Stream = SessionIndex::Stream;
  std::vector<sync::FrameRef> pressure;
  std::map<std::tuple<std::int64_t, std::uint32_t, std::uint64_t>, std::int64_t> camera_mapped;
  for (const auto& sc : in.clocks) {
    const bool is_pressure = sc.stream < 0;
    const std::int64_t device = is_pressure ? in.pressure_device_id : in.camera_device_ids[std::size_t(sc.stream)];
    const Stream kind = is_pressure ? Stream::Pressure : Stream::Camera;
    for (std::size_t k = 0; k < sc.segments.size(); ++k) {
      const std::int64_t from = k == 0 ? INT64_MIN : sc.segments[k].first_arrival_ns;
      const std::int64_t to = k + 1 < sc.segments.size() ? sc.segments[k + 1].first_arrival_ns : INT64_MAX;
      const auto& f = sc.segments[k].fit;
      index.remap(kind, device, from, to, f.x0, f.offset_ns, f.skew, sc.segments[k].latency_ns);
    }
    for (const auto& m : index.mapped(kind, device)) {
      if (is_pressure) pressure.push_back({-1, m.sequence, m.mapped_ns, m.connection});
      else camera_mapped[{device, m.connection, m.sequence}] = m.mapped_ns;
    }
  }
  std::sort(pressure.begin(), pressure.end(), [](const auto& a, const auto& b) { return a.t_ns < b.t_ns; });

  RealignResult result;
  for (auto& [id, members] : index.sample_members()) {
    SampleRecord s;
    s.index = id;
    std::int64_t lo = INT64_MAX, hi = INT64_MIN;
    std::vector<std::int64_t> times;
    for (const auto& m : members) {
      const auto it = camera_mapped.find({m.device_id, m.connection, m.sequence});
      if (it == camera_mapped.end()) continue;
      times.push_back(it->second);
      lo = std::min(lo, it->second);
      hi = std::max(hi, it->second);
    }
    if (times.empty()) continue;
    // Mean relative to the earliest, so the sum cannot overflow.
    std::int64_t rel = 0;
    for (auto t : times) rel += t - lo;
    s.t_ns = lo + rel / std::int64_t(times.size());
    s.span_ns = hi - lo;
    for (const auto& m : members) {
      const auto it = camera_mapped.find({m.device_id, m.connection, m.sequence});
      if (it != camera_mapped.end()) s.cameras.push_back({m.device_id, m.connection, m.sequence, it->second - s.t_ns});
    }
    const auto p = sync::pair_nearest(pressure.begin(), pressure.end(), s.t_ns, in.max_offset_ns);
    auto ref = [&](const std::optional<sync::FrameRef>& f) -> std::optional<SampleFrameRef> {
      if (!f) return std::nullopt;
      return SampleFrameRef{in.pressure_device_id, f->connection, f->sequence, f->t_ns - s.t_ns};
    };
    s.pressure = ref(p.nearest);
    s.pressure_before = ref(p.before);
    s.pressure_after = ref(p.after);
    index.update_sample(s);
    ++result.samples;
  }
  return result;
}

}  // namespace pvcap
