#include "sim/session_replay.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include <fmt/format.h>

#include "core/rig_config.h"
#include "core/time.h"
#include "storage/index/session_reader.h"
#include "sync/timeline.h"

namespace pvcap::sim {

namespace {
// Times beyond this (~30 years of nanoseconds) are damage, not a session: refused, so the replay's
// arithmetic never overflows.
constexpr std::int64_t kMaxTimeNs = std::int64_t(1) << 60;
bool plausible(std::int64_t t) { return t > -kMaxTimeNs && t < kMaxTimeNs; }

// The first frame leaves this long after the first device starts: time for the others to start.
// Short enough that a Sensel asked for its first frame answers before the driver gives up (0.5 s).
constexpr std::int64_t kLeadNs = 200'000'000;

// At a replay rate r the recorded device times are compressed (r > 1) or stretched about each
// clock's start, so the device clocks still tick one second a second while the frames come r times
// as often; a clock that went back (a device restarted) starts a new stretch there.
class DeviceClockScale {
 public:
  explicit DeviceClockScale(double rate) : rate_(rate) {}
  std::int64_t operator()(std::int64_t device) {
    if (!started_ || device < last_) start_ = device, started_ = true;
    last_ = device;
    return start_ + std::int64_t(std::llround(double(device - start_) / rate_));
  }

 private:
  double rate_;
  bool started_ = false;
  std::int64_t start_ = 0, last_ = 0;
};

// The same for the Sensel's 32-bit microsecond clock in a frame's payload (bytes 2-5, little
// endian), rewritten in place; it wraps every 71 minutes.
class SenselClockScale {
 public:
  explicit SenselClockScale(double rate) : rate_(rate) {}
  void operator()(std::vector<std::uint8_t>& payload) {
    if (payload.size() < 6) return;
    std::uint32_t us = 0;
    for (int i = 0; i < 4; ++i) us |= std::uint32_t(payload[2 + std::size_t(i)]) << (8 * i);
    const auto step = std::int32_t(us - last_);  // a wrap is a small step forward
    if (!started_ || step < 0)
      start_ = us, elapsed_ = 0, started_ = true;
    else
      elapsed_ += std::uint32_t(step);
    last_ = us;
    const auto scaled = std::uint32_t(start_ + std::uint64_t(std::llround(double(elapsed_) / rate_)));
    for (int i = 0; i < 4; ++i) payload[2 + std::size_t(i)] = std::uint8_t(scaled >> (8 * i));
  }

 private:
  double rate_;
  bool started_ = false;
  std::uint32_t start_ = 0, last_ = 0;
  std::uint64_t elapsed_ = 0;
};
}  // namespace

Result<std::shared_ptr<SessionReplay>> SessionReplay::open(const std::filesystem::path& session_dir, double rate) {
  const auto db_path = session_dir / "session.db";
  if (!std::filesystem::exists(db_path))
    return Error{fmt::format("{}: not a pvcap session (no session.db) - nothing to replay", session_dir.string())};
  auto opened = SessionReader::open(session_dir);
  if (!opened) return opened.error();
  SessionReader& reader = *opened.value();
  std::shared_ptr<SessionReplay> r(new SessionReplay());
  r->dir_ = session_dir;
  r->rate_ = rate;
  r->anchor_ns_ = reader.info().started_host_ns;
  if (!plausible(r->anchor_ns_))
    return Error{fmt::format("{}: the session's start is an impossible time (a damaged index)", db_path.string())};
  std::int64_t sensel_latency_ns = 0;
  try {
    const RigConfig rig = parse_rig_config(reader.info().rig_config, reader.info().rig_path);
    r->grid_hz_ = sample_rate_hz(rig);
    if (rig.sensel) sensel_latency_ns = rig.sensel->latency_ns;
  } catch (const UserError& e) {
    return Error{
        fmt::format("{}: the rig file stored with the session cannot be read: {}", db_path.string(), e.what())};
  }

  // Which sample stores which camera frame (samples by position, as SessionReader numbers them).
  auto samples = reader.sample_infos();
  if (!samples) return samples.error();
  std::map<std::tuple<std::int64_t, std::int64_t, std::int64_t>, std::int64_t> stored;
  for (std::size_t i = 0; i < samples.value().size(); ++i)
    for (const auto& c : samples.value()[i].cameras)
      stored[{c.device_id, std::int64_t(c.connection), std::int64_t(c.sequence)}] = std::int64_t(i);

  // Every camera frame that arrived whole and was put on the session clock, in the order sent.
  std::int64_t first = INT64_MAX;
  for (const CameraInfo& info : reader.cameras()) {
    auto timing = reader.frame_timing(info.device_id);
    if (!timing) return timing.error();
    auto rows = std::move(timing.value());
    std::sort(rows.begin(), rows.end(), [](const FrameTiming& a, const FrameTiming& b) {
      return std::tie(a.connection, a.sequence) < std::tie(b.connection, b.sequence);
    });
    Camera c;
    c.name = info.name;
    DeviceClockScale scale(rate);
    for (const FrameTiming& row : rows) {
      if (!row.mapped_ns || row.frame_id == 0 || !row.good) continue;
      ReplayCameraFrame f{row.frame_id, row.device_ns, *row.mapped_ns, -1};
      if (!plausible(f.device_ns) || !plausible(f.t_ns))
        return Error{
            fmt::format("{}: camera {} has a frame at an impossible time (a damaged index)", db_path.string(), c.name)};
      if (rate != 1.0) f.device_ns = scale(f.device_ns);
      if (row.kept) {
        const auto it = stored.find({info.device_id, std::int64_t(row.connection), std::int64_t(row.sequence)});
        if (it != stored.end()) f.sample = it->second;
      }
      // Its device clock read device_ns when the exposure began, half the exposure before the image's
      // instant t_ns (what the recorder added back).
      c.clock.emplace_back(f.t_ns - info.stamp_to_instant_ns, f.device_ns);
      c.frames.push_back(f);
    }
    std::sort(c.clock.begin(), c.clock.end());
    if (!c.frames.empty()) first = std::min(first, c.frames.front().t_ns);
    r->cameras_.push_back(std::move(c));
  }

  // The Sensel's frames as they came, each due when it reached the host (its mapped time plus the
  // latency the rig declared, which the recorder subtracts again).
  if (const auto& sensel = reader.pressure_device()) {
    r->sensel_serial_ = sensel->serial;
    auto payloads = reader.pressure_payloads();
    if (!payloads) return payloads.error();
    SenselClockScale scale(rate);
    for (auto& p : payloads.value()) {
      if (!plausible(p.mapped_ns))
        return Error{fmt::format("{}: a pressure frame at an impossible time (a damaged index)", db_path.string())};
      r->pressure_.push_back({std::move(p.payload), p.mapped_ns + sensel_latency_ns});
      if (rate != 1.0) scale(r->pressure_.back().payload);
    }
    if (!r->pressure_.empty()) first = std::min(first, r->pressure_.front().t_ns);
  }
  if (first == INT64_MAX)
    return Error{fmt::format("{}: the session holds no frame on its clock - nothing to replay", session_dir.string())};
  r->first_t_ns_ = first;
  return r;
}

Result<std::size_t> SessionReplay::camera_index(const std::string& name) const {
  std::vector<std::string> names;
  for (std::size_t i = 0; i < cameras_.size(); ++i) {
    if (cameras_[i].name == name) return i;
    names.push_back(cameras_[i].name);
  }
  return Error{fmt::format("{}: the replayed session has no camera '{}' (it has: {})", dir_.string(), name,
                           fmt::join(names, ", "))};
}

std::int64_t SessionReplay::origin_for(std::int64_t now_ns) const {
  // The session's first frame leaves kLeadNs from now; the anchor's stand-in is then moved to the
  // next lattice point of the grid, so the re-recording's ticks fall where the recording's did.
  const double period_ns = 1e9 / grid_hz_;
  const auto origin = now_ns + kLeadNs - std::int64_t(double(first_t_ns_ - anchor_ns_) / rate_);
  return sync::grid_lattice_floor(origin + std::int64_t(std::ceil(period_ns)), grid_hz_);
}

std::int64_t SessionReplay::start(std::int64_t now_ns) {
  std::lock_guard lock(mu_);
  if (!origin_) origin_ = origin_for(now_ns);
  return *origin_;
}

bool SessionReplay::started() const {
  std::lock_guard lock(mu_);
  return origin_.has_value();
}

std::int64_t SessionReplay::origin() const {
  {
    std::lock_guard lock(mu_);
    if (origin_) return *origin_;
  }
  return origin_for(host_now().ns);  // not started: as if starting now
}

std::int64_t SessionReplay::due_ns(std::int64_t t_ns) const {
  return origin() + std::int64_t(std::llround(double(t_ns - anchor_ns_) / rate_));
}

std::int64_t SessionReplay::session_time(std::int64_t host_ns) const {
  return anchor_ns_ + std::int64_t(std::llround(double(host_ns - origin()) * rate_));
}

std::int64_t SessionReplay::camera_device_time(std::size_t c, std::int64_t host_ns) const {
  const auto& clock = cameras_[c].clock;
  const std::int64_t t = session_time(host_ns);
  if (clock.empty()) return t;
  // Between two recorded frames: on the line through them; outside: at the device's nominal rate
  // (its recorded times are scaled by the rate: one second of the replay's host clock a second).
  const auto hi = std::lower_bound(clock.begin(), clock.end(), std::make_pair(t, INT64_MIN));
  auto beyond = [&](std::int64_t session_ns) { return std::int64_t(std::llround(double(session_ns) / rate_)); };
  if (hi == clock.begin()) return clock.front().second + beyond(t - clock.front().first);
  if (hi == clock.end()) return clock.back().second + beyond(t - clock.back().first);
  const auto lo = std::prev(hi);
  if (hi->first == lo->first) return lo->second;
  const double f = double(t - lo->first) / double(hi->first - lo->first);
  return lo->second + std::int64_t(std::llround(f * double(hi->second - lo->second)));
}

}  // namespace pvcap::sim
