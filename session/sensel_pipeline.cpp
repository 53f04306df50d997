#include "session/sensel_pipeline.h"

#include <algorithm>
#include <memory>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "core/fault_injection.h"
#include "core/loss_runs.h"
#include "storage/video/frame_checksum.h"

namespace pvcap::session {

using namespace std::chrono_literals;

namespace {
constexpr std::size_t kHistoryFrames = 16'000;  // ~2 minutes at medium detail's ~125 Hz
}

Result<std::unique_ptr<SenselPipeline>> SenselPipeline::open(const SenselRigConfig& cfg,
                                                             const SenselPipelineOptions& options,
                                                             const std::atomic<bool>& cancel) {
  std::unique_ptr<SenselPipeline> r(new SenselPipeline());
  r->config_ = cfg;
  r->stall_ = options.stall;
  const std::string path = cfg.tty;
  sensel::SenselDevice::TransportFactory factory;
  if (cfg.usb_serial) {
    factory = [serial = *cfg.usb_serial](const std::string&) { return sensel::open_usb(serial); };
  } else {
    // A Morph plugged back in may come back under another name (ttyACM0 -> ttyACM1 while the old
    // node is still held): when its tty is gone, the session's Morph is looked for by its serial
    // among the ports where a Morph may be (a simulated rig publishes its own in a folder of its own).
    const std::filesystem::path ports = options.ports_dir;
    factory = [ports, current = std::make_shared<std::string>(path)](
                  const std::string& session_serial) -> Result<std::unique_ptr<sensel::Transport>> {
      auto t = sensel::open_tty(*current);
      // Only when its node is gone: a port that exists but fails (busy, no permission) is said as is.
      std::error_code ec;
      if (t || session_serial.empty() || std::filesystem::exists(*current, ec)) return t;
      std::vector<std::string> others;
      for (auto& c : sensel::sensel_tty_candidates(ports))
        if (c != *current) others.push_back(std::move(c));
      auto found = sensel::find_tty_with_serial(session_serial, others);
      if (!found) return t;  // still away: the reconnect loop tries again in a second
      spdlog::warn("sensel: {} is gone; the session's Morph (serial {}) is back on {}", *current, session_serial,
                   found.value());
      *current = found.value();
      return sensel::open_tty(*current);
    };
  }
  const char* key = cfg.usb_serial ? "sensel.usb" : "sensel.tty";
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(options.wait_s);
  for (;;) {
    auto d = sensel::SenselDevice::open(
        factory, [raw = r.get()](const sensel::SenselEvent& e) { raw->on_event(e); }, options.queue_frames);
    if (d) {
      r->device_ = std::move(d.value());
      break;
    }
    if (cancel.load() || std::chrono::steady_clock::now() >= deadline)
      return Error{fmt::format("Sensel ({} in the rig file, line {}): {}", key, cfg.line, d.error().message)};
    std::this_thread::sleep_for(200ms);
  }
  if (Status s = r->device_->configure({.scan_detail = cfg.scan_detail,
                                        .dynamic_baseline = cfg.dynamic_baseline,
                                        .frame_rate_cap = cfg.frame_rate_cap});
      !s.ok())
    return Error{"Sensel: " + s.error().message};
  const auto& info = r->device_->info();
  spdlog::info("sensel: Sensel Morph serial {} firmware {} on {}, grid {}x{} (scan detail {}), dynamic baselining {}",
               info.serial, info.firmware, r->connection(), info.grid.cols, info.grid.rows,
               cfg.scan_detail == 0 ? "high" : "medium", cfg.dynamic_baseline ? "on" : "off");
  return r;
}

SenselPipeline::~SenselPipeline() { stop(); }

DeviceRecord SenselPipeline::device_record() const {
  const auto& info = device_->info();
  nlohmann::json j = {{"scan_detail", config_.scan_detail == 0 ? "high" : "medium"},
                      {"grid", {info.grid.cols, info.grid.rows, info.grid.xscale, info.grid.yscale}},
                      {"dynamic_baseline", config_.dynamic_baseline},
                      {"frame_rate_cap", config_.frame_rate_cap},
                      {"latency_ns", config_.latency_ns}};
  if (config_.usb_serial)
    j["usb"] = *config_.usb_serial;
  else
    j["tty"] = config_.tty;
  return DeviceRecord{"sensel", "sensel", "Sensel", "Morph", info.serial, connection(), info.firmware, j.dump()};
}

std::string SenselPipeline::connection() const {
  if (!config_.usb_serial) return config_.tty;
  return config_.usb_serial->empty() ? "usb" : "usb:" + *config_.usb_serial;
}

Status SenselPipeline::start(RecordingStore& writer, std::int64_t device_id, sync::SessionTimeline& timeline) {
  writer_ = &writer;
  device_id_ = device_id;
  timeline_ = &timeline;
  if (Status s = device_->start(); !s.ok()) return s;
  worker_ = std::thread([this] { run(); });
  return {};
}

void SenselPipeline::stop() {
  if (device_) device_->stop();
  if (worker_.joinable()) worker_.join();
  writer_ = nullptr;
}

std::uint64_t SenselPipeline::rejected_frames() const {
  std::uint64_t n = 0;
  for (const auto& [why, count] : device_->rejected()) n += count;
  return n;
}

std::vector<PressurePoint> SenselPipeline::history(std::int64_t from_ns, std::int64_t to_ns) const {
  std::lock_guard lock(history_mu_);
  std::vector<PressurePoint> out;
  for (const auto& p : history_)
    if (p.mapped_ns >= from_ns && p.mapped_ns < to_ns) out.push_back(p);
  return out;
}

PressureSnapshot SenselPipeline::latest() const {
  std::lock_guard lock(history_mu_);
  return latest_;
}

void SenselPipeline::on_event(const sensel::SenselEvent& e) {
  using K = sensel::SenselEvent::Kind;
  if (e.kind == K::Reconnected)
    spdlog::warn("{}", e.message);
  else
    spdlog::error("{}", e.message);
  static const char* kinds[] = {"sensel_stall", "sensel_garbage", "sensel_unplugged", "sensel_reconnected",
                                "sensel_wrong_device"};
  static_assert(std::size(kinds) == std::size_t(sensel::SenselEvent::Kind::WrongDevice) + 1);
  RecordingStore* w = writer_;
  if (!w) return;
  w->record(EventRecord{e.at.ns, kinds[int(e.kind)], device_id_, e.message});
  // The frames it would have sent while it was away: lost, with the reason.
  if (e.kind == K::Reconnected && e.missed > 0)
    w->record(DropRecord{device_id_, e.connection, 0, e.missed, "unplugged", e.at.ns});
  // The previous connection's last frames, received but dropped for want of room in the queue.
  if (e.kind == K::Reconnected && !e.dropped.empty() && e.connection > 0)
    record_losses(*w, e.connection - 1, e.dropped.front(), e.dropped.back() + 1, e.dropped, e.at.ns);
}

void SenselPipeline::record_losses(RecordingStore& writer, std::uint32_t connection, std::uint64_t from,
                                   std::uint64_t to, const std::vector<std::uint64_t>& dropped, std::int64_t host_ns) {
  for_each_loss_run(from, to, dropped, [&](std::uint64_t first, std::uint64_t count, bool by_queue) {
    writer.record(
        DropRecord{device_id_, connection, first, count, by_queue ? "queue_overflow" : "not_received", host_ns});
  });
}

void SenselPipeline::run() {
  auto& q = device_->samples();
  RecordingStore& writer = *writer_.load();
  // A worker that falls behind, on purpose (core/fault_injection.h): tests meet a full queue.
  std::optional<Stall> stall = stall_;
  std::int64_t first_ns = 0;
  while (!q.closed_and_empty()) {
    auto s = q.pop_for(100ms);
    if (!s) continue;
    if (first_ns == 0) first_ns = s->host_ts.ns;
    if (stall && s->host_ts.ns - first_ns >= std::int64_t(stall->after_s * 1e9)) {
      std::this_thread::sleep_for(std::chrono::duration<double>(stall->seconds));
      stall.reset();
    }
    // Every sequence between the previous frame of this connection and this one is lost: dropped
    // by the driver for want of room in its queue, or never received (the device's counter says).
    std::uint64_t from = s->sequence - s->lost_before;
    if (previous_ && previous_->first == s->connection)
      from = previous_->second + 1;
    else if (!s->dropped_before.empty())
      from = std::min(from, s->dropped_before.front());
    record_losses(writer, s->connection, from, s->sequence, s->dropped_before, s->host_ts.ns);
    previous_ = {s->connection, s->sequence};
    // The clock model fits when the answer began to arrive (the midpoint is the stamp's best
    // single guess, but an arrival is what a latency floor bounds; its first bytes come before
    // the rest of a frame's 64-byte packets).
    const std::int64_t mapped =
        timeline_->pressure_frame(s->connection, s->sequence, s->device_ts, s->first_byte_ts).ns;
    PressureRecord rec{device_id_,
                       s->connection,
                       s->sequence,
                       s->lost_before,
                       s->device_ts.ns,
                       s->host_ts.ns,
                       s->host_wait_ns,
                       s->grid.cols,
                       s->grid.rows,
                       s->grid.xscale,
                       s->grid.yscale,
                       {},
                       mapped,
                       0,
                       {}};
    // The counts again in the store's portable form (zlib on the index's thread), for readers
    // without the Sensel codec; the device's payload is kept as it came.
    if (s->frame.pressure) {
      rec.base = s->frame.pressure->base;
      const auto summary = sensel::summarize_pressure(s->frame.pressure->counts, s->grid);
      std::lock_guard lock(history_mu_);
      history_.push_back({mapped, s->sequence, summary});
      if (history_.size() > kHistoryFrames) history_.pop_front();
      latest_.grid = s->grid;
      latest_.counts = s->frame.pressure->counts;
      latest_.mapped_ns = mapped;
      rec.counts = std::move(s->frame.pressure->counts);
    }
    // Its checksum, of the payload as the device sent it (storage/video/frame_checksum.h): verify checks it.
    rec.checksum = crc32_of(s->payload.data(), s->payload.size());
    rec.payload = std::move(s->payload);
    writer.record(std::move(rec));
    stored_.fetch_add(1, std::memory_order_relaxed);
    last_host_ns_.store(s->host_ts.ns, std::memory_order_relaxed);
  }
}

}  // namespace pvcap::session
