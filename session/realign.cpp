#include "session/realign.h"

#include <algorithm>
#include <climits>
#include <map>
#include <tuple>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/rig_config.h"
#include "core/time.h"
#include "session/sample_record.h"
#include "storage/writer/recover.h"
#include "sync/group_rule.h"
#include "sync/timeline.h"

namespace pvcap {

namespace {

void add_event(SessionIndex& index, const char* kind, std::string message) {
  index.add_event(EventRecord{host_now().ns, kind, std::nullopt, std::move(message)});
}

// The live grouper's limit for the session in `index`, from the rig it recorded.
std::int64_t recorded_group_limit(SessionIndex& index) {
  double hz = 60;
  if (const auto rig = index.recorded_rig()) {
    try {
      hz = grouping_rate_hz(parse_rig_config(rig->text, rig->path));
    } catch (const std::exception&) {
      // A rig this version no longer reads: the rule's default rate, as the recorder's own.
    }
  }
  return sync::Grouper::limit_for(hz);
}

struct TimedMember {
  SampleFrameRef ref;
  std::int64_t t_ns = 0;
};

std::string done_message(const RealignResult& r, std::int64_t limit) {
  std::string message = fmt::format("{} samples re-paired with the final clock fits in {:.1f} s", r.samples, r.seconds);
  if (r.frames_out_of_groups == 0) return message;
  std::vector<std::string> per_camera;
  for (const auto& c : r.left_by_camera)
    per_camera.push_back(fmt::format("{} {} of {}", c.camera, c.left, c.in_samples));
  return message + fmt::format(
                       "; {} camera frames left groups the final fits put wider than {:.2f} ms (reason "
                       "outside_its_group: {})",
                       r.frames_out_of_groups, double(limit) / 1e6, fmt::join(per_camera, ", "));
}

}  // namespace

std::string RealignResult::cameras_that_left(double share) const {
  std::vector<std::string> named;
  for (const auto& c : left_by_camera)
    if (double(c.left) > share * double(c.in_samples))
      named.push_back(fmt::format("{} ({} of its {} sampled frames)", c.camera, c.left, c.in_samples));
  return fmt::format("{}", fmt::join(named, ", "));
}

std::string RealignResult::many_left_warning() const {
  const std::string cameras = cameras_that_left(kManyLeft);
  if (cameras.empty()) return cameras;
  return fmt::format(
      "the final clock fits put frames of {} more than {:.2f} ms from the other cameras', so they left their samples "
      "(frames.reason outside_its_group; their images stay in the videos). The report's sync self-check measures "
      "each camera's offset",
      cameras, double(group_limit_ns) / 1e6);
}

bool realign_pending(SessionIndex& index) { return index.realign_pending(); }

Result<std::optional<RealignResult>> realign_if_needed(const std::filesystem::path& dir, bool interrupted,
                                                       const std::function<void(const std::string&)>& progress) {
  try {
    SessionIndex index = SessionIndex::open_for_update(dir / "session.db");
    if (!interrupted && !index.realign_pending()) return std::optional<RealignResult>{};
    RealignOptions o;
    o.progress = progress;
    return std::optional<RealignResult>{realign(index, o)};
  } catch (const std::exception& e) {
    return Error{fmt::format("{}: re-mapping the timeline failed: {}", (dir / "session.db").string(), e.what())};
  }
}

RealignResult realign(SessionIndex& index, const RealignOptions& o) {
  using Stream = SessionIndex::Stream;
  auto say = [&](const std::string& line) {
    if (o.progress) o.progress(line);
  };
  const std::int64_t t0 = host_now().ns;
  RealignResult result;
  sqlite::Database& db = index.db();
  {
    sqlite::Transaction tx(db);
    add_event(index, "realign_started", "re-mapping every frame with the final clock fits");
    tx.commit();
  }

  // Step 1: every frame's instant from its segment's fit.
  std::vector<sync::FrameRef> pressure;
  std::map<std::tuple<std::int64_t, std::uint32_t, std::uint64_t>, std::int64_t> camera_mapped;
  std::int64_t pressure_device_id = 0;
  {
    sqlite::Transaction tx(db);
    for (const auto& sc : index.stored_clocks()) {
      const Stream kind = sc.pressure ? Stream::Pressure : Stream::Camera;
      for (std::size_t k = 0; k < sc.segments.size(); ++k) {
        const std::int64_t from = k == 0 ? INT64_MIN : sc.segments[k].first_arrival_ns;
        const std::int64_t to = k + 1 < sc.segments.size() ? sc.segments[k + 1].first_arrival_ns : INT64_MAX;
        const auto& f = sc.segments[k];
        index.remap(kind, sc.device_id, from, to, f.x0, f.offset_ns, f.skew, f.latency_ns);
        ++result.segments;
      }
      for (const auto& m : index.mapped(kind, sc.device_id)) {
        if (sc.pressure)
          pressure.push_back({-1, m.sequence, m.mapped_ns, m.connection});
        else
          camera_mapped[{sc.device_id, m.connection, m.sequence}] = m.mapped_ns;
      }
      if (sc.pressure) pressure_device_id = sc.device_id;
    }
    tx.commit();
  }
  std::sort(pressure.begin(), pressure.end(), [](const auto& a, const auto& b) { return a.t_ns < b.t_ns; });
  say(fmt::format("re-mapping: {} clock segments applied; re-pairing the samples", result.segments));

  // Step 2: every sample's instant and pairing, committed in steps; a group the final fits widen
  // beyond the grouping rule loses the frames outside it.
  const std::int64_t limit = o.group_limit_ns > 0 ? o.group_limit_ns : recorded_group_limit(index);
  result.group_limit_ns = limit;
  const auto members = index.sample_members();
  std::map<std::int64_t, RealignResult::CameraLeft> by_camera;
  for (const auto& m : members)
    for (const auto& f : m.frames) ++by_camera[f.device_id].in_samples;
  const std::size_t step = std::max<std::size_t>(1, o.samples_per_step);
  for (std::size_t begin = 0; begin < members.size(); begin += step) {
    sqlite::Transaction tx(db);
    const std::size_t end = std::min(members.size(), begin + step);
    for (std::size_t i = begin; i < end; ++i) {
      const auto& [id, tick_ns, stored_t_ns, stored_span_ns, frames] = members[i];
      std::vector<TimedMember> timed;
      for (const auto& m : frames) {
        const auto it = camera_mapped.find({m.device_id, m.connection, m.sequence});
        if (it != camera_mapped.end()) timed.push_back({m, it->second});
      }
      std::sort(timed.begin(), timed.end(), [](const auto& a, const auto& b) { return a.t_ns < b.t_ns; });
      std::vector<std::int64_t> times;
      for (const auto& m : timed) times.push_back(m.t_ns);
      // The live grouper's rule, with the final fits: frames it now puts too far apart leave.
      const auto [first, last] = sync::members_within(times, limit, tick_ns);
      std::vector<session::MappedCameraFrame> kept;
      for (std::size_t k = 0; k < timed.size(); ++k) {
        if (k < first || k >= last) {
          index.leave_sample(id, timed[k].ref);
          ++result.frames_out_of_groups;
          ++by_camera[timed[k].ref.device_id].left;
          continue;
        }
        kept.push_back({timed[k].ref.device_id, timed[k].ref.connection, timed[k].ref.sequence, timed[k].t_ns});
      }
      times = std::vector<std::int64_t>(times.begin() + std::ptrdiff_t(first), times.begin() + std::ptrdiff_t(last));
      // None of its frames stored (lost at an interruption): its instant stays the live timeline's,
      // and its pressure is still re-paired against the re-mapped pressure frames.
      const sync::GroupTime at = kept.empty() ? sync::GroupTime{stored_t_ns, stored_span_ns} : sync::group_time(times);
      const auto p = sync::pair_nearest(pressure.begin(), pressure.end(), at.t_ns, o.max_offset_ns);
      // (Its grid tick stays as recorded: update_sample rewrites the instant, offsets and pairing only.)
      const SampleRecord s = session::sample_record(id, 0, tick_ns, at, kept, p, pressure_device_id);
      index.update_sample(s);
      ++result.samples;
    }
    result.seconds = double(host_now().ns - t0) / 1e9;
    if (end == members.size()) {
      for (auto& [device_id, c] : by_camera)
        if (c.left > 0) {
          c.camera = index.device_name(device_id);
          result.left_by_camera.push_back(c);
        }
      add_event(index, "realign_done", done_message(result, limit));
    }
    tx.commit();
    if (end < members.size()) say(fmt::format("re-mapping: {} of {} samples re-paired", end, members.size()));
  }
  if (members.empty()) {
    sqlite::Transaction tx(db);
    add_event(index, "realign_done", "no samples to re-pair");
    tx.commit();
  }
  result.seconds = double(host_now().ns - t0) / 1e9;
  return result;
}

Result<std::vector<std::string>> recover_and_realign(const std::filesystem::path& dir,
                                                     const std::function<void(const std::string&)>& progress) {
  auto recovered = recover_session(dir, progress);
  if (!recovered) return recovered.error();
  auto realigned = realign_if_needed(dir, recovered.value().was_interrupted, progress);
  if (!realigned) return realigned.error();
  auto done = recovered.value().done;
  if (const auto& r = realigned.value()) {
    done.push_back(fmt::format("timeline re-mapped with the stored clock fits: {} samples re-paired", r->samples));
    if (const std::string warning = r->many_left_warning(); !warning.empty()) done.push_back(warning);
  }
  return done;
}

}  // namespace pvcap
