// The Recording's lights (docs/lighting.md): the rig file's lights switched through the cameras'
// output lines, each command and its read-back a row of the session, and the images' word on each:
// the light check at the start learns what every light adds to every camera's level, a thread then
// confirms every switch (how late, in frames and ms), and a take's lighting is what its levels show.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <thread>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "capture/aravis_camera.h"
#include "core/time.h"
#include "lighting/light_monitor.h"
#include "lighting/lighting_code.h"
#include "session/recording.h"

namespace pvcap::session {

using namespace std::chrono_literals;

namespace {
lighting::LightNames light_names(const RigConfig& rig) {
  lighting::LightNames names;
  for (const LightConfig& l : rig.lights) names.push_back(l.name);
  return names;
}

// The first instant after `from_ns` at which some camera's view left `previous` (per channel): at
// least a third of its regions beyond 5 x their noise (and 2 levels), in three of its frames running
// (the simulator's timecode, a hand at rest or one frame's noise are not a lamp).
std::optional<std::int64_t> first_view_change(const lighting::LightMonitor& monitor,
                                              const std::vector<double>& previous, const std::vector<double>& noise,
                                              std::int64_t from_ns, std::int64_t to_ns) {
  std::optional<std::int64_t> first;
  const std::size_t per = lighting::kMeterRegions;
  for (std::size_t camera = 0; camera * per < monitor.channels(); ++camera) {
    std::map<std::int64_t, int> changed_regions;  // per frame
    for (std::size_t c = camera * per; c < (camera + 1) * per && c < previous.size(); ++c) {
      if (std::isnan(previous[c])) continue;
      const double threshold = std::max(2.0, 5 * (std::isnan(noise[c]) ? 0.0 : noise[c]));
      for (const auto& l : monitor.levels(c, from_ns, to_ns))
        changed_regions[l.t_ns] += std::abs(l.level - previous[c]) > threshold;
    }
    int running = 0;
    std::int64_t run_start = 0;
    for (const auto& [t, n] : changed_regions) {
      running = n * 3 >= int(per) ? running + 1 : 0;
      if (running == 1) run_start = t;
      if (running == 3) {
        if (!first || run_start < *first) first = run_start;
        break;
      }
    }
  }
  return first;
}

// A light check's step: long enough for every camera's frames at the slowest rate to settle and count.
constexpr auto kSettle = 250ms;
constexpr auto kChangeTimeout = 2500ms;  // a light that does not change any camera's level by then is out
constexpr std::int64_t kConfirmTimeoutNs = 5'000'000'000;
}  // namespace

Result<std::uint32_t> Recording::switch_lights(std::uint32_t mask, const std::string& why) {
  const lighting::LightNames names = light_names(rig_);
  std::uint32_t read_back = 0;
  nlohmann::json cams = nlohmann::json::object();
  std::optional<Error> failure;
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    const auto& lights = rig_.cameras[c].lights;
    if (lights.empty()) continue;
    std::uint32_t local = 0;  // this camera's lights, in its own order
    for (std::size_t k = 0; k < lights.size(); ++k)
      for (std::size_t i = 0; i < rig_.lights.size(); ++i)
        if (rig_.lights[i].name == lights[k].name && (mask >> i & 1u)) local |= 1u << k;
    auto set = cameras_[c]->set_lights(local);
    if (!set) {
      failure = set.error();
      continue;
    }
    for (std::size_t k = 0; k < lights.size(); ++k)
      for (std::size_t i = 0; i < rig_.lights.size(); ++i)
        if (rig_.lights[i].name == lights[k].name && (set.value() >> k & 1u)) read_back |= 1u << i;
    lighting::LightNames own;  // its lights' letters, in its order
    for (const auto& l : lights) own.push_back(l.name);
    cams[rig_.cameras[c].name] = lighting::lighting_code(set.value(), own);
  }
  const std::int64_t at = host_now().ns;
  nlohmann::json d = {{"code", lighting::lighting_code(mask, names)},
                      {"read_back", lighting::lighting_code(read_back, names)},
                      {"cameras", cams},
                      {"why", why}};
  if (failure) d["error"] = failure->message;
  ProtocolEventRecord e;
  e.host_ns = at;
  e.kind = "lighting";
  e.detail = d.dump();
  if (!post(std::move(e))) spdlog::warn("lighting {}: the command could not be committed to the session", d["code"]);
  if (failure) return *failure;
  if (read_back != mask)
    spdlog::warn("lighting {}: the cameras read back {}", lighting::lighting_code(mask, names),
                 lighting::lighting_code(read_back, names));
  return read_back;
}

std::optional<std::string> Recording::set_lighting(const std::string& code) {
  if (rig_.lights.empty()) return code;  // a label only
  const lighting::LightNames names = light_names(rig_);
  auto mask = lighting::parse_lighting(code, names);
  if (!mask) {
    spdlog::error("{}", mask.error().message);
    return std::nullopt;
  }
  // From what the images show now (a lamp slower than the last switch may not have followed it yet),
  // or, before the light check or without frames, from what was last commanded.
  const std::uint32_t from = lighting_shown_now();
  auto set = switch_lights(mask.value(), "lighting");
  if (!set) {
    spdlog::error("{}", set.error().message);
    return std::nullopt;
  }
  // From the moment the cameras have read it back (the lines are switched by then), so a loaded host's
  // slow control round trips are not counted against the lamps.
  const std::int64_t command_ns = host_now().ns;
  std::lock_guard lock(light_mu_);
  lighting_mask_ = mask.value();
  lighting_commanded_ = true;
  if (from != mask.value()) pending_switches_.push_back({command_ns, from, mask.value()});
  return lighting::lighting_code(mask.value(), names);
}

std::uint32_t Recording::lighting_shown_now() const {
  std::lock_guard lock(light_mu_);
  if (!light_model_ || !light_monitor_) return lighting_mask_;
  const std::int64_t now = host_now().ns;
  const auto levels = light_monitor_->medians(now - 150'000'000, now);
  if (std::all_of(levels.begin(), levels.end(), [](double l) { return std::isnan(l); })) return lighting_mask_;
  return light_model_->classify(levels);
}

std::string Recording::lighting_now() const {
  std::lock_guard lock(light_mu_);
  return lighting_commanded_ ? lighting::lighting_code(lighting_mask_, light_names(rig_)) : std::string();
}

std::string Recording::lighting_seen(std::int64_t from_ns, std::int64_t to_ns) const {
  std::lock_guard lock(light_mu_);
  if (!light_model_ || !light_monitor_) return "";
  return lighting::lighting_code(light_model_->classify(light_monitor_->medians(from_ns, to_ns)), light_model_->names);
}

// Every light off, then each on alone: per camera, its dark level and noise, and what each light adds.
// A light that changes no camera's level within kChangeTimeout is out (or wired to another lamp).
void Recording::run_light_check() {
  const lighting::LightNames names = light_names(rig_);
  auto& monitor = *light_monitor_;
  const auto wait_until = [this](std::int64_t until_ns) {
    while (host_now().ns < until_ns && !stop_requested_.load()) std::this_thread::sleep_for(10ms);
  };
  // The frames of a step's window have arrived: every camera has one past its end (a loaded host's
  // frames reach the monitor a few hundred ms after their instant), or 1.5 s passed.
  const auto wait_for_frames_past = [&](std::int64_t end_ns) {
    const std::int64_t give_up = host_now().ns + 1'500'000'000;
    for (std::size_t camera = 0; camera * lighting::kMeterRegions < monitor.channels();) {
      bool arrived = false;
      for (int r = 0; r < lighting::kMeterRegions && !arrived; ++r)
        arrived = !monitor.levels(camera * lighting::kMeterRegions + std::size_t(r), end_ns, INT64_MAX).empty();
      if (arrived || host_now().ns > give_up || stop_requested_.load())
        ++camera;
      else
        std::this_thread::sleep_for(10ms);
    }
  };
  const auto settle_ns = std::chrono::nanoseconds(kSettle).count();
  std::vector<double> noise;
  std::int64_t t0 = host_now().ns;
  if (!switch_lights(0, "light check: every light off")) return;
  wait_until(t0 + 2 * settle_ns);
  const std::int64_t dark_end = host_now().ns;
  wait_for_frames_past(dark_end);
  std::vector<double> dark = monitor.medians(t0 + settle_ns, dark_end, &noise);
  std::vector<double> previous = dark;
  std::vector<std::vector<double>> alone;
  nlohmann::json lights = nlohmann::json::array();
  for (std::size_t i = 0; i < names.size() && !stop_requested_.load(); ++i) {
    t0 = host_now().ns;
    if (!switch_lights(1u << i, fmt::format("light check: {} alone", names[i]))) return;
    // The first frame whose view left the previous step's: in some camera, at least a third of its
    // regions changed beyond their noise, in two frames running (a hand moving over one region is not
    // a lamp). That is the light's latency.
    std::optional<std::int64_t> changed;
    const auto deadline = t0 + std::chrono::nanoseconds(kChangeTimeout).count();
    while (!changed && !stop_requested_.load() && host_now().ns < deadline) {
      std::this_thread::sleep_for(20ms);
      changed = first_view_change(monitor, previous, noise, t0, host_now().ns);
    }
    const std::int64_t from = changed ? *changed + settle_ns / 4 : t0;
    wait_until(from + settle_ns);
    const std::int64_t end = host_now().ns;
    wait_for_frames_past(end);
    alone.push_back(monitor.medians(from, end));
    previous = alone.back();
    lights.push_back({{"light", names[i]}, {"latency_ms", changed ? double(*changed - t0) / 1e6 : -1.0}});
  }
  lighting::LightModel model = lighting::learn_light_model(names, dark, noise, alone);
  std::vector<std::string> problems;
  for (std::size_t i = 0; i < names.size() && i < lights.size(); ++i) {
    lights[i]["seen"] = model.seen(i);
    if (!model.seen(i)) lights[i]["latency_ms"] = nullptr;  // what changed then was the light before it going off
    if (!model.seen(i))
      problems.push_back(fmt::format("light {}: no camera saw it come on (a lamp out, or its line wired to another "
                                     "light?): takes lit by {} will be flagged",
                                     names[i], names[i]));
  }
  ProtocolEventRecord e;
  e.kind = "light_check";
  e.detail = nlohmann::json{{"model", model}, {"lights", lights}, {"problems", problems}}.dump();
  post(std::move(e));
  for (const auto& p : problems) warn(p);
  std::lock_guard lock(light_mu_);
  light_model_ = std::move(model);
  lighting_mask_ = names.empty() ? 0 : 1u << (names.size() - 1);  // the check's last step
}

// The light thread: each switch, confirmed once every camera that can tell the two lightings apart
// shows the new one in two frames running; said late when that took more than two frames.
void Recording::confirm_switches() {
  while (light_thread_running_.load()) {
    std::this_thread::sleep_for(50ms);
    std::vector<PendingSwitch> pending;
    std::optional<lighting::LightModel> model;
    {
      std::lock_guard lock(light_mu_);
      pending = pending_switches_;
      model = light_model_;
    }
    if (!model || pending.empty()) continue;
    const std::int64_t now = host_now().ns;
    std::vector<std::int64_t> done;
    for (const PendingSwitch& p : pending) {
      // Only the frames before the next switch speak of this one.
      std::int64_t until = now;
      for (const PendingSwitch& q : pending)
        if (q.command_ns > p.command_ns) until = std::min(until, q.command_ns);
      const auto seen =
          lighting::switch_seen(*model, *light_monitor_, p.command_ns, p.from, p.to, until, lighting::kMeterRegions);
      const bool over = now - p.command_ns > kConfirmTimeoutNs || until < now;
      if (!seen.confirmed && !over && seen.visible) continue;
      const std::string code = lighting::lighting_code(p.to, model->names);
      nlohmann::json d = {{"code", code},
                          {"from", lighting::lighting_code(p.from, model->names)},
                          {"confirmed", seen.confirmed},
                          {"visible", seen.visible}};
      ProtocolEventRecord e;
      e.kind = "lighting_seen";
      if (seen.confirmed) {
        d["delay_ms"] = seen.delay_ms;
        d["frames"] = seen.frames;
        d["on_time"] = seen.frames <= 2;
        if (seen.frames > 2)
          warn(fmt::format("lighting {}: the images showed it {:.0f} ms after the command ({} frames late): a slow "
                           "lamp?",
                           code, seen.delay_ms, seen.frames));
      } else if (until < now && seen.visible) {
        d["superseded"] = true;  // switched again before the cameras could show it: nothing to say
      } else {
        std::vector<std::string> waiting;
        for (int c : seen.channels_waiting) {
          const std::string& name = rig_.cameras[std::size_t(c / lighting::kMeterRegions)].name;
          if (std::find(waiting.begin(), waiting.end(), name) == waiting.end()) waiting.push_back(name);
        }
        d["cameras_waiting"] = waiting;
        warn(seen.visible ? fmt::format("lighting {}: {} never showed it (within 5 s)", code, fmt::join(waiting, ", "))
                          : fmt::format("lighting {}: no camera can tell it from {} (a light the check did not see)",
                                        code, d["from"].get<std::string>()));
      }
      e.detail = d.dump();
      post(std::move(e));
      done.push_back(p.command_ns);
    }
    std::lock_guard lock(light_mu_);
    std::erase_if(pending_switches_, [&](const PendingSwitch& p) {
      return std::find(done.begin(), done.end(), p.command_ns) != done.end();
    });
  }
}

void Recording::stop_light_thread() {
  light_thread_running_.store(false);
  if (light_thread_.joinable()) light_thread_.join();
}

}  // namespace pvcap::session
