#include "sync/session_timeline.h"

#include <algorithm>

namespace pvcap::sync {
namespace {
constexpr std::int64_t kSnapshotPeriodNs = 1'000'000'000;

ClockModelOptions with_latency(std::int64_t latency_ns, std::int64_t stamp_to_instant_ns = 0) {
  ClockModelOptions o;
  o.latency_ns = latency_ns;
  o.stamp_to_instant_ns = stamp_to_instant_ns;
  return o;
}
}  // namespace

SessionTimeline::SessionTimeline(TimelineConfig config, std::function<void(SampleOut)> on_sample,
                                 std::function<void(ClockSnapshot)> on_clock)
    : config_(std::move(config)),
      on_sample_(std::move(on_sample)),
      on_clock_(std::move(on_clock)),
      pressure_{ClockModel(with_latency(config_.pressure_latency_ns)), {}, 0, 0},
      grouper_(config_.cameras, Grouper::limit_for(config_.camera_hz), config_.group_wait_ns),
      subsampler_(config_.anchor_ns, config_.sample_hz),
      aligner_(config_.pressure_window_ns, config_.pressure_max_offset_ns),
      decisions_(std::size_t(config_.cameras)) {
  for (int c = 0; c < config_.cameras; ++c) {
    const std::int64_t latency =
        std::size_t(c) < config_.camera_latency_ns.size() ? config_.camera_latency_ns[std::size_t(c)] : 0;
    const std::int64_t to_instant = std::size_t(c) < config_.camera_stamp_to_instant_ns.size()
                                        ? config_.camera_stamp_to_instant_ns[std::size_t(c)]
                                        : 0;
    cameras_.push_back({ClockModel(with_latency(latency, to_instant)), {}, 0, 0});
  }
}

void SessionTimeline::emit(Stream& s, int id, std::int64_t host_ns, int segment, const ClockModel::Segment& seg,
                           bool probed, bool current) {
  ClockSnapshot snap{id, host_ns, segment, seg.fit, seg.latency_ns, probed, 0, 0, 0, 0};
  if (current) {
    snap.pairs = s.model.pairs();
    snap.envelope_points = s.model.envelope_points();
    auto& r = s.residuals;
    if (!r.empty()) {
      std::nth_element(r.begin(), r.begin() + std::ptrdiff_t(r.size() / 2), r.end());
      snap.residual_p50_ns = r[r.size() / 2];
      std::nth_element(r.begin(), r.begin() + std::ptrdiff_t(r.size() * 99 / 100), r.end());
      snap.residual_p99_ns = r[r.size() * 99 / 100];
    }
    r.clear();
  }
  if (on_clock_) on_clock_(snap);
}

std::int64_t SessionTimeline::map(Stream& s, int id, std::int64_t device_ns, std::int64_t arrival_ns) {
  if (s.model.add(device_ns, arrival_ns)) {
    // A reset: the segment that ended is stored with its last fit (just before this arrival), and
    // the new one from this arrival on, so a re-mapping from the store finds where each begins.
    ++s.resets;
    const auto& segments = s.model.segments();
    const auto& ended = segments[segments.size() - 2];
    emit(s, id, arrival_ns - 1, s.model.segment() - 1, ended, s.last_probed, false);
    s.next_snapshot_ns = arrival_ns;
  }
  s.last_probed = s.model.probed();
  s.residuals.push_back(s.model.residual(device_ns, arrival_ns));
  s.last_arrival_ns = arrival_ns;
  if (arrival_ns >= s.next_snapshot_ns) {
    s.next_snapshot_ns = arrival_ns + kSnapshotPeriodNs;
    emit(s, id, arrival_ns, s.model.segment(), s.model.segments().back(), s.model.probed(), true);
  }
  return s.model.map(device_ns);
}

void SessionTimeline::final_snapshots() {
  auto last = [&](Stream& s, int id) {
    if (s.model.segment() < 0) return;
    emit(s, id, s.last_arrival_ns, s.model.segment(), s.model.segments().back(), s.model.probed(), true);
  };
  for (std::size_t c = 0; c < cameras_.size(); ++c) last(cameras_[c], int(c));
  if (config_.has_pressure) last(pressure_, -1);
}

HostNs SessionTimeline::camera_frame(int c, std::uint32_t connection, std::uint64_t sequence, DeviceNs device,
                                     HostNs arrival) {
  const std::int64_t t = map(cameras_[std::size_t(c)], c, device.ns, arrival.ns);
  std::vector<SampleOut> done;
  {
    std::lock_guard lock(mu_);
    newest_camera_ns_ = std::max(newest_camera_ns_, t);
    if (!grouper_.add({c, sequence, t, connection}))
      decisions_[std::size_t(c)].push_back({connection, sequence, false, "late_for_its_instant"});
    advance(done, false);
  }
  for (auto& s : done) on_sample_(std::move(s));
  return HostNs{t};
}

HostNs SessionTimeline::pressure_frame(std::uint32_t connection, std::uint64_t sequence, DeviceNs device,
                                       HostNs arrival) {
  const std::int64_t t = map(pressure_, -1, device.ns, arrival.ns);
  std::vector<SampleOut> done;
  {
    std::lock_guard lock(mu_);
    aligner_.add_pressure({-1, sequence, t, connection});
    advance(done, false);
  }
  for (auto& s : done) on_sample_(std::move(s));
  return HostNs{t};
}

void SessionTimeline::camera_probe(int c, DeviceNs device, HostNs host_lo, HostNs host_hi) {
  cameras_[std::size_t(c)].model.add_probe(device.ns, host_lo.ns, host_hi.ns);
}

std::vector<FrameDecision> SessionTimeline::take_decisions(int c) {
  std::lock_guard lock(mu_);
  std::vector<FrameDecision> out;
  out.swap(decisions_[std::size_t(c)]);
  return out;
}

void SessionTimeline::flush() {
  std::vector<SampleOut> done;
  {
    std::lock_guard lock(mu_);
    advance(done, true);
  }
  for (auto& s : done) on_sample_(std::move(s));
}

void SessionTimeline::decide(const Group& g, bool kept, const char* reason) {
  for (const auto& m : g.members)
    if (m) decisions_[std::size_t(m->stream)].push_back({m->connection, m->sequence, kept, kept ? "" : reason});
}

void SessionTimeline::settle(HostNs before) {
  std::vector<SampleOut> done;
  {
    std::lock_guard lock(mu_);
    advance(done, false, before.ns);
  }
  for (auto& s : done) on_sample_(std::move(s));
}

void SessionTimeline::advance(std::vector<SampleOut>& done, bool flush, std::int64_t settled_before) {
  std::vector<Subsampler::Sample> samples;
  std::vector<Group> discarded;
  for (const Group& g : grouper_.take(flush, settled_before))
    for (auto& s : subsampler_.add(g, &discarded)) samples.push_back(std::move(s));
  if (flush)
    for (auto& s : subsampler_.flush()) samples.push_back(std::move(s));
  else if (settled_before != INT64_MIN)  // every group left begins within the limit before it, or after
    for (auto& s : subsampler_.settle(settled_before - grouper_.limit_ns())) samples.push_back(std::move(s));
  for (const Group& g : discarded) decide(g, false, "subsampled");
  for (auto& s : samples) {
    decide(s.group, true, "");
    SampleOut out{next_sample_++, s.tick, s.tick_ns, std::move(s.group), {}};
    aligner_.add_sample(out.group.t_ns, out.index);
    awaiting_pressure_.emplace(out.index, std::move(out));
  }
  const std::int64_t give_up = !config_.has_pressure            ? INT64_MAX
                               : newest_camera_ns_ == INT64_MIN ? INT64_MIN
                                                                : newest_camera_ns_ - config_.pressure_give_up_ns;
  for (auto& [index, pairing] : aligner_.take(flush, give_up)) {
    auto it = awaiting_pressure_.find(index);
    if (it == awaiting_pressure_.end()) continue;
    it->second.pressure = std::move(pairing);
    done.push_back(std::move(it->second));
    awaiting_pressure_.erase(it);
  }
}

SessionTimeline::Counts SessionTimeline::counts() const {
  std::lock_guard lock(mu_);
  Counts c;
  c.groups_complete = grouper_.complete_groups();
  c.groups_incomplete = grouper_.incomplete_groups();
  c.late_camera_frames = grouper_.late_frames();
  c.missed_ticks = subsampler_.missed_ticks();
  c.samples = next_sample_;
  c.unpaired = aligner_.unpaired();
  for (const auto& s : cameras_) c.clock_resets.push_back(s.resets);
  c.clock_resets.push_back(pressure_.resets);
  return c;
}

}  // namespace pvcap::sync
