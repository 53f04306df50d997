#include "capture/sensel_device.h"

#include <pthread.h>
#include <sched.h>

#include <chrono>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

namespace pvcap::sensel {

namespace {
constexpr std::size_t kMaxDroppedKept = 100'000;  // sequences of frames dropped while the queue stays full
constexpr int kReadTimeoutMs = 500;               // the official library's single-attempt limit: longer is a stall

// Runs `f` and stamps it with the midpoint of CLOCK_MONOTONIC before and after.
template <typename F>
auto stamped(F&& f) {
  const HostNs before = host_now();
  auto result = f();
  const HostNs after = host_now();
  return std::make_tuple(HostNs{before.ns + (after.ns - before.ns) / 2}, after.ns - before.ns, std::move(result));
}
}  // namespace

SenselDevice::SenselDevice(TransportFactory factory, EventHandler on_event, std::size_t queue_frames)
    : factory_(std::move(factory)), on_event_(std::move(on_event)), queue_(queue_frames) {}

SenselDevice::~SenselDevice() { stop(); }

Result<std::unique_ptr<SenselDevice>> SenselDevice::open(TransportFactory factory, EventHandler on_event,
                                                         std::size_t queue_frames) {
  std::unique_ptr<SenselDevice> d(new SenselDevice(std::move(factory), std::move(on_event), queue_frames));
  auto t = d->factory_("");
  if (!t) return t.error();
  d->transport_ = std::move(t.value());
  if (Status s = d->open_sequence(); !s.ok()) return s.error();
  return d;
}

void SenselDevice::emit(SenselEvent::Kind kind, std::string message) {
  emit(SenselEvent{kind, host_now(), std::move(message)});
}

void SenselDevice::emit(SenselEvent e) {
  if (on_event_) on_event_(e);
}

std::map<std::string, std::uint64_t> SenselDevice::rejected() const {
  std::lock_guard lock(rejected_mu_);
  return rejected_;
}

void SenselDevice::flush_input() {
  inbox_.clear();
  std::uint8_t buf[512];
  for (int i = 0; i < 5; ++i) {
    auto n = transport_->read(buf, 10);
    if (!n || n.value() == 0) break;
  }
}

Result<Response> SenselDevice::transact(const std::vector<std::uint8_t>& command, Expect expect, std::uint8_t reg,
                                        std::uint8_t size) {
  timed_out_ = false;
  first_byte_ = HostNs{0};
  if (Status s = transport_->write(command); !s.ok()) return s.error();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(kReadTimeoutMs);
  std::uint8_t buf[1024];
  for (;;) {
    Response r = parse_response(inbox_, expect, reg, size);
    if (r.state != Response::State::NeedMore) {
      inbox_.erase(inbox_.begin(), inbox_.begin() + std::ptrdiff_t(std::min(r.consumed, inbox_.size())));
      if (r.state == Response::State::Ok && r.ack == kAsyncData) continue;  // not ours in sync mode
      return r;
    }
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      timed_out_ = true;
      return Error{fmt::format("{}: no complete answer to register 0x{:02x} within {} ms ({} bytes)",
                               transport_->describe(), reg, kReadTimeoutMs, inbox_.size())};
    }
    auto n = transport_->read(buf, int(left.count()));
    if (!n) return n.error();
    if (n.value() > 0 && first_byte_.ns == 0) first_byte_ = host_now();
    inbox_.insert(inbox_.end(), buf, buf + n.value());
  }
}

Status SenselDevice::write_reg(std::uint8_t reg, std::span<const std::uint8_t> data) {
  auto r = transact(command_write(reg, data), Expect::Write, reg);
  if (!r) return r.error();
  if (r.value().state != Response::State::Ok)
    return Error{fmt::format("{}: writing register 0x{:02x}: {}", transport_->describe(), reg, r.value().error)};
  return {};
}

Status SenselDevice::write_variable(std::uint8_t reg, std::span<const std::uint8_t> data) {
  if (running_.load()) return Error{"a variable-size register cannot be written while the Sensel streams"};
  auto step = [&](const std::vector<std::uint8_t>& command, Expect expect) -> Status {
    auto r = transact(command, expect, reg);
    if (!r) return r.error();
    if (r.value().state != Response::State::Ok)
      return Error{fmt::format("{}: writing register 0x{:02x} ({} bytes): {}", transport_->describe(), reg, data.size(),
                               r.value().error)};
    return {};
  };
  if (Status s = step(command_write_variable_header(reg, std::uint32_t(data.size())), Expect::WriteVariableHeader);
      !s.ok())
    return s;
  for (std::size_t at = 0; at < data.size(); at += kWvsMaxChunk)
    if (Status s = step(command_write_variable_chunk(data.subspan(at, std::min(kWvsMaxChunk, data.size() - at))),
                        Expect::WriteVariableChunk);
        !s.ok())
      return s;
  return {};
}

Result<SenselInfo> SenselDevice::probe(std::unique_ptr<Transport> transport) {
  SenselDevice d(nullptr, nullptr, 1);  // a probe streams nothing
  d.transport_ = std::move(transport);
  if (Status s = d.open_sequence(/*soft_reset=*/false); !s.ok()) return s.error();
  SenselInfo info = d.info_;
  d.transport_.reset();  // nothing to stop: scanning was never touched
  return info;
}

Status SenselDevice::open_sequence(bool soft_reset) {
  const std::string where = transport_->describe();
  auto read = [&](std::uint8_t reg, std::uint8_t size) -> Result<std::vector<std::uint8_t>> {
    auto r = size ? transact(command_read(reg, size), Expect::Read, reg, size)
                  : transact(command_read_variable(reg), Expect::ReadVariable, reg);
    if (!r) return r.error();
    if (r.value().state != Response::State::Ok)
      return Error{fmt::format("{}: reading register 0x{:02x}: {}", where, reg, r.value().error)};
    return r.value().data;
  };
  flush_input();
  auto magic = read(reg::kMagic, 6);
  if (!magic) return Error{fmt::format("{} (is this a Sensel Morph?)", magic.error().message)};
  if (std::string(magic.value().begin(), magic.value().end()) != kMagicText)
    return Error{fmt::format("{}: not a Sensel Morph (magic is not S3NS31)", where)};
  if (soft_reset) {
    const std::uint8_t one[] = {1};
    if (Status s = write_reg(reg::kSoftReset, one); !s.ok()) return s;
  }
  auto fw = read(reg::kFirmwareInfo, 10);
  if (!fw) return fw.error();
  info_.firmware = fmt::format("{}.{}.{}", fw.value()[1], fw.value()[2], fw.value()[3] | (fw.value()[4] << 8));
  auto serial = read(reg::kSerialNumber, 0);
  if (!serial) return serial.error();
  info_.serial.clear();
  for (std::uint8_t c : serial.value())
    if (c != 0xFF && c != 0) info_.serial.push_back(char(c));
  auto meta = read(reg::kCompressionMetadata, 0);
  if (!meta) return meta.error();
  auto grid = grid_from_metadata(meta.value());
  if (!grid) return Error{fmt::format("{}: {}", where, grid.error().message)};
  info_.grid = grid.value();
  return {};
}

Status SenselDevice::apply_config() {
  const std::uint8_t detail[] = {std::uint8_t(config_.scan_detail)};
  if (Status s = write_reg(reg::kScanDetail, detail); !s.ok()) return s;
  const std::uint8_t content[] = {config_.content};
  if (Status s = write_reg(reg::kFrameContent, content); !s.ok()) return s;
  const std::uint8_t dynamic[] = {std::uint8_t(config_.dynamic_baseline ? 1 : 0)};
  if (Status s = write_reg(reg::kDynamicBaseline, dynamic); !s.ok()) return s;
  if (config_.frame_rate_cap > 0) {
    const std::uint8_t rate[] = {std::uint8_t(config_.frame_rate_cap), std::uint8_t(config_.frame_rate_cap >> 8)};
    if (Status s = write_reg(reg::kScanFrameRate, rate); !s.ok()) return s;
  }
  // The grid follows the scan detail: read it again rather than assume.
  auto r = transact(command_read_variable(reg::kCompressionMetadata), Expect::ReadVariable, reg::kCompressionMetadata);
  if (!r) return r.error();
  if (r.value().state != Response::State::Ok) return Error{r.value().error};
  auto grid = grid_from_metadata(r.value().data);
  if (!grid) return grid.error();
  info_.grid = grid.value();
  return {};
}

Status SenselDevice::verify_config() {
  auto read = [&](std::uint8_t r, std::uint8_t size, const char* name) -> Result<int> {
    auto a = transact(command_read(r, size), Expect::Read, r, size);
    if (!a) return a.error();
    if (a.value().state != Response::State::Ok || a.value().data.size() < size)
      return Error{fmt::format("{}: reading back the {} (register 0x{:02x}): {}", transport_->describe(), name, r,
                               a.value().error)};
    const auto& d = a.value().data;
    return size == 2 ? d[0] | (d[1] << 8) : int(d[0]);
  };
  // The content asked that this model has (a Morph without an accelerometer keeps its bit clear).
  auto supported = read(reg::kContentSupported, 1, "supported frame content");
  if (!supported) return supported.error();
  struct Setting {
    std::uint8_t reg;
    const char* name;
    int asked;
    std::uint8_t size;
  };
  std::vector<Setting> settings = {{reg::kScanDetail, "scan detail", config_.scan_detail, 1},
                                   {reg::kFrameContent, "frame content", config_.content & supported.value(), 1},
                                   {reg::kDynamicBaseline, "dynamic baseline", config_.dynamic_baseline ? 1 : 0, 1}};
  if (config_.frame_rate_cap > 0) settings.push_back({reg::kScanFrameRate, "frame rate cap", config_.frame_rate_cap, 2});
  for (const Setting& setting : settings) {
    auto got = read(setting.reg, setting.size, setting.name);
    if (!got) return got.error();
    if (got.value() != setting.asked)
      return Error{fmt::format("{}: the Morph's {} reads back {}, not the {} set (register 0x{:02x}): pvcap does not "
                               "record with settings other than the rig file's",
                               transport_->describe(), setting.name, got.value(), setting.asked, setting.reg)};
  }
  return {};
}

Status SenselDevice::configure(const SenselConfig& config) {
  config_ = config;
  if (Status s = apply_config(); !s.ok()) return s;
  return verify_config();
}

Status SenselDevice::start() {
  const std::uint8_t sync[] = {1};
  if (Status s = write_reg(reg::kScanEnabled, sync); !s.ok()) return s;
  // A Morph may fall back to medium detail when a scan starts after a stop or a reset: its settings
  // are set again now that it scans, and read back.
  Status settled = apply_config();
  if (settled.ok()) settled = verify_config();
  if (!settled.ok()) {
    const std::uint8_t off[] = {0};
    (void)write_reg(reg::kScanEnabled, off);
    return settled;
  }
  session_serial_ = info_.serial;  // what a reconnect must find again
  session_grid_ = info_.grid;
  running_.store(true);
  thread_ = std::thread([this] { stream_loop(); });
  return {};
}

void SenselDevice::stop() {
  if (running_.exchange(false) && thread_.joinable()) thread_.join();
  if (transport_) {
    const std::uint8_t off[] = {0};
    (void)write_reg(reg::kScanEnabled, off);
  }
  // Let go of the Morph as the devices stop (its port or USB interface free at once for the next
  // program, not when the session object goes).
  transport_.reset();
  queue_.close();
}

void SenselDevice::reopen() {
  auto t = factory_(session_serial_);
  if (!t) return;
  transport_ = std::move(t.value());
  const std::uint8_t sync[] = {1};
  if (!open_sequence().ok()) {
    transport_.reset();
    return;
  }
  // Only the session's own Morph is recorded again: another one (a swapped cable, a second sensor on
  // the bench) would mix two sensors' data in one stream.
  if (info_.serial != session_serial_) {
    if (info_.serial != refused_serial_)  // said once per Morph, not at every retry
      emit(SenselEvent::Kind::WrongDevice,
           fmt::format("{}: a different Sensel Morph (serial {}) answered where the session's (serial {}) was "
                       "unplugged; it is NOT recorded - plug the session's Morph back in",
                       transport_->describe(), info_.serial, session_serial_));
    refused_serial_ = info_.serial;
    transport_.reset();
    return;
  }
  if (!apply_config().ok() || !write_reg(reg::kScanEnabled, sync).ok()) {
    transport_.reset();
    return;
  }
  // Its settings again once it scans, read back: one that does not take is not recorded.
  Status settled = apply_config();
  if (settled.ok()) settled = verify_config();
  if (!settled.ok()) {
    if (settled.error().message != refused_settings_)  // said once, not at every retry
      emit(SenselEvent::Kind::WrongDevice,
           fmt::format("{}; the Morph came back but is NOT recorded", settled.error().message));
    refused_settings_ = settled.error().message;
    transport_.reset();
    return;
  }
  if (!(info_.grid == session_grid_)) {
    emit(SenselEvent::Kind::WrongDevice,
         fmt::format("{}: the Morph came back scanning a {}x{} grid, not the session's {}x{}; it is NOT recorded",
                     transport_->describe(), info_.grid.cols, info_.grid.rows, session_grid_.cols, session_grid_.rows));
    transport_.reset();
    return;
  }
  counter_ = SequenceUnwrapper(8, false);  // a power-cycled device restarts its counter
  clock_ = SequenceUnwrapper(32, false);   // and its clock
  ++connection_;                           // so sequences never repeat within a connection
  first_device_ns_ = -1, connection_frames_ = 0;
  SenselEvent e{SenselEvent::Kind::Reconnected, host_now(),
                fmt::format("{}: Sensel reconnected (serial {}), streaming again as connection {}",
                            transport_->describe(), info_.serial, connection_)};
  e.connection = connection_;
  e.dropped = std::move(dropped_);
  dropped_.clear();
  e.away_ns = e.at.ns - unplugged_at_.ns;
  e.missed = std::uint64_t(std::max<std::int64_t>(0, e.away_ns) / std::max<std::int64_t>(1, frame_period_ns_));
  emit(std::move(e));
}

void SenselDevice::stream_loop() {
  // The stamps are only as good as this thread's wake-ups: where allowed (root, or an rtprio
  // limit), it runs at a real-time priority. It blocks on the device nearly all the time.
  sched_param rt{};
  rt.sched_priority = 20;
  if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &rt) != 0)
    spdlog::debug("sensel: streaming thread stays at normal priority (no permission for SCHED_FIFO)");
  auto reject = [&](const std::string& why) {
    std::lock_guard lock(rejected_mu_);
    ++rejected_[why];
  };
  while (running_.load()) {
    if (!transport_) {  // unplugged: reopen every second (stop() does not wait for the second to pass)
      for (int i = 0; i < 20 && running_.load(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
      if (running_.load()) reopen();
      continue;
    }
    auto [host, wait_ns, r] = stamped(
        [&] { return transact(command_read_variable(reg::kReadFrame), Expect::ReadVariable, reg::kReadFrame); });
    if (!r) {
      const std::string msg = r.error().message;
      if (timed_out_) {  // stall: the device answered nothing whole in time
        reject("stall");
        emit(SenselEvent::Kind::Stall, msg);
        flush_input();
      } else {
        emit(SenselEvent::Kind::Unplugged,
             fmt::format("{}; everything captured so far is kept, reopening every second", msg));
        unplugged_at_ = host_now();
        if (connection_frames_ > 1 && last_device_ns_ > first_device_ns_)  // its rate until now
          frame_period_ns_ = (last_device_ns_ - first_device_ns_) / std::int64_t(connection_frames_ - 1);
        transport_.reset();
      }
      continue;
    }
    if (r.value().state != Response::State::Ok) {
      reject(r.value().error.find("checksum") != std::string::npos ? "checksum" : "bad response");
      emit(SenselEvent::Kind::Garbage, fmt::format("{}: frame rejected: {}", transport_->describe(), r.value().error));
      flush_input();
      continue;
    }
    auto frame = parse_frame(r.value().data, info_.grid);
    if (!frame) {
      reject("undecodable frame");
      emit(SenselEvent::Kind::Garbage,
           fmt::format("{}: frame rejected: {}", transport_->describe(), frame.error().message));
      continue;
    }
    PressureSample s;
    s.host_ts = host;
    s.host_wait_ns = wait_ns;
    s.first_byte_ts = first_byte_.ns ? first_byte_ : HostNs{host.ns + wait_ns / 2};
    const auto step = counter_.next(frame.value().counter);
    s.sequence = step.sequence;
    s.lost_before = step.missing;
    lost_.fetch_add(step.missing);
    auto tick = clock_.next(frame.value().timestamp_us);
    if (tick.out_of_order) {                  // the device clock went back: it restarted. Unwrap afresh; the
      clock_ = SequenceUnwrapper(32, false);  // timeline's clock model starts a new segment.
      tick = clock_.next(frame.value().timestamp_us);
    }
    s.device_ts = DeviceNs{std::int64_t(tick.sequence) * 1000};
    s.connection = connection_;
    if (first_device_ns_ < 0) first_device_ns_ = s.device_ts.ns;
    last_device_ns_ = s.device_ts.ns;
    ++connection_frames_;
    s.grid = info_.grid;
    s.frame = std::move(frame.value());
    s.payload = std::move(r.value().data);
    frames_.fetch_add(1);
    s.dropped_before = std::move(dropped_);
    dropped_.clear();
    if (!queue_.try_push(s)) {
      overflows_.fetch_add(1);
      dropped_ = std::move(s.dropped_before);
      if (dropped_.size() < kMaxDroppedKept) dropped_.push_back(s.sequence);
    }
  }
}

Result<std::string> find_tty_with_serial(const std::string& serial, const std::vector<std::string>& candidates) {
  std::vector<std::string> seen;
  for (const auto& path : candidates) {
    auto t = open_tty(path);
    if (!t) continue;  // gone, not ours to open, or held by another pvcap
    auto info = SenselDevice::probe(std::move(t.value()));
    if (!info) continue;  // not a Morph
    if (info.value().serial == serial) return path;
    seen.push_back(fmt::format("{} (serial {})", path, info.value().serial));
  }
  return Error{fmt::format("no Sensel Morph with serial {} on {}{}{}", serial,
                           candidates.empty() ? "any tty" : fmt::format("{}", fmt::join(candidates, ", ")),
                           seen.empty() ? "" : "; found: ", fmt::format("{}", fmt::join(seen, ", ")))};
}

}  // namespace pvcap::sensel
