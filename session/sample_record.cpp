#include "session/sample_record.h"

namespace pvcap::session {

SampleRecord sample_record(std::uint64_t index, std::int64_t tick, std::int64_t tick_ns, sync::GroupTime at,
                           const std::vector<MappedCameraFrame>& cameras, const sync::Pairing& pressure,
                           std::int64_t pressure_device_id) {
  SampleRecord r{index, tick, tick_ns, at.t_ns, at.span_ns, {}, {}, {}, {}};
  for (const auto& c : cameras) r.cameras.push_back({c.device_id, c.connection, c.sequence, c.t_ns - at.t_ns});
  auto ref = [&](const std::optional<sync::FrameRef>& f) -> std::optional<SampleFrameRef> {
    if (!f) return std::nullopt;
    return SampleFrameRef{pressure_device_id, f->connection, f->sequence, f->t_ns - at.t_ns};
  };
  r.pressure = ref(pressure.nearest);
  r.pressure_before = ref(pressure.before);
  r.pressure_after = ref(pressure.after);
  return r;
}

ClockModelRecord clock_record(std::int64_t device_id, const sync::ClockSnapshot& c) {
  return ClockModelRecord{device_id,       c.host_ns,         c.segment,         c.fit.x0,
                          c.fit.offset_ns, c.fit.skew,        c.latency_ns,      c.probed ? "latch" : "arrivals",
                          c.pairs,         c.envelope_points, c.residual_p50_ns, c.residual_p99_ns};
}

}  // namespace pvcap::session
