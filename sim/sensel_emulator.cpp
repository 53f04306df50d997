#include "sim/sensel_emulator.h"

#include <cmath>
#include <cstring>

#include "codec/sensel_protocol.h"
#include "sim/hand.h"

namespace pvcap::sim {

using namespace sensel;

SenselScene fingertip_scene(double x_mm, double y_mm, double peak_grams, double period_s) {
  SimSenselConfig c;
  c.press_x_mm = x_mm;
  c.press_y_mm = y_mm;
  c.peak_grams = peak_grams;
  c.period_s = period_s;
  return hand_scene(std::make_shared<Hand>(c));
}

SenselScene hand_scene(std::shared_ptr<const Hand> hand) {
  SenselScene s;
  s.pressure = [hand](std::int64_t true_ns, const Grid& g) {
    std::vector<std::uint16_t> counts(std::size_t(g.cells()), 0);
    const HandPose p = hand->pose_at(true_ns);
    if (p.force <= 0) return counts;
    const double cell_mm_x = 1.25 * g.xscale, cell_mm_y = 1.25 * g.yscale;
    const double sigma_mm = 4.0;  // a fingertip's footprint
    for (int r = 0; r < g.rows; ++r)
      for (int c = 0; c < g.cols; ++c) {
        const double dx = c * cell_mm_x - p.x_mm, dy = r * cell_mm_y - p.y_mm;
        const double grams = p.peak_grams * p.force * std::exp(-(dx * dx + dy * dy) / (2 * sigma_mm * sigma_mm));
        const double raw = grams * 8.0;  // counts = g * 2^UNIT_SHIFT_FORCE
        if (raw > 3.5) counts[std::size_t(r * g.cols + c)] = std::uint16_t(std::min(raw, 32000.0));
      }
    return counts;
  };
  return s;
}

SenselEmulator::SenselEmulator(SenselScene scene, SenselClock clock, std::string serial)
    : scene_(std::move(scene)), clock_(clock), serial_(std::move(serial)) {
  soft_reset();
}

void SenselEmulator::soft_reset() {
  regs_.fill(0);
  wvs_ = {};
  variable_regs_.clear();
  std::memcpy(&regs_[reg::kMagic], kMagicText, 6);
  const std::uint8_t fw[10] = {1, 0, 16, 78, 0, 1, 3, 0, 1, 0};  // protocol 1, v0.16.78 rel 1, device 3 rev 1
  std::memcpy(&regs_[reg::kFirmwareInfo], fw, 10);
  regs_[reg::kSensorCols] = 185;
  regs_[reg::kSensorRows] = 105;
  const std::uint32_t w = 230000, h = 130000;
  std::memcpy(&regs_[reg::kWidthUm], &w, 4);
  std::memcpy(&regs_[reg::kHeightUm], &h, 4);
  regs_[reg::kScanFrameRate] = 125;
  regs_[reg::kScanDetail] = 1;       // medium
  regs_[reg::kFrameContent] = 0x07;  // pressure, labels, contacts
  regs_[reg::kContentSupported] = 0x0F;
  regs_[reg::kContactsMaxCount] = 16;
  regs_[reg::kBaselineEnabled] = 1;
  regs_[reg::kDynamicBaseline] = 1;  // on by default, as on the device
  regs_[0xA0] = 8;
  regs_[reg::kUnitShiftForce] = 3;
  regs_[0xA3] = 4;
}

Grid SenselEmulator::grid() const { return regs_[reg::kScanDetail] == 0 ? kHighDetail : kMediumDetail; }

std::vector<std::uint8_t> SenselEmulator::frame_payload(std::int64_t now_ns) {
  Frame f;
  f.content = regs_[reg::kFrameContent] & 0x0F;
  if (drop_fraction_ > 0 && std::uniform_real_distribution<double>(0, 1)(drop_rng_) < drop_fraction_)
    ++counter_;  // a scan the device lost: the host sees its counter skip
  f.counter = counter_++;
  f.timestamp_us = clock_.at(now_ns);
  const Grid g = grid();
  std::vector<std::uint16_t> counts =
      scene_.pressure ? scene_.pressure(now_ns, g) : std::vector<std::uint16_t>(std::size_t(g.cells()), 0);
  if (f.content & kPressure) f.pressure = PressureImage{3, counts};
  bool touched = false;
  for (auto c : counts) touched |= c > 3;
  if (f.content & kLabels) {
    std::vector<std::uint8_t> labels(counts.size(), kNoLabel);
    for (std::size_t i = 0; i < counts.size(); ++i)
      if (counts[i] > 3) labels[i] = 0;
    f.labels = std::move(labels);
  }
  if (f.content & kContacts) {
    f.contact_groups = regs_[reg::kContactsMask] & 0x0F;
    if (touched) {
      Contact c;
      c.id = 0;
      c.state = 2;
      std::uint32_t total = 0;
      for (auto v : counts) total += v;
      c.total_force = std::uint16_t(std::min<std::uint32_t>(total, 65535));
      f.contacts.push_back(c);
    }
  }
  if (f.content & kAccel) f.accel = Accel{0, 0, 15600};
  if (truth_) {
    *truth_ << int(f.counter) << ',' << now_ns << ',' << f.timestamp_us << '\n';
    if (f.counter % 32 == 0) truth_->flush();
  }
  return encode_frame(f);
}

std::int64_t SenselEmulator::scan_period_ns(std::size_t payload_bytes) const {
  return grid() == kHighDetail ? 19'600'000 + std::int64_t(12'500 * payload_bytes) : 8'000'000;
}

std::vector<std::uint8_t> SenselEmulator::async_frames_due(std::int64_t now_ns) {
  std::vector<std::uint8_t> out;
  if (regs_[reg::kScanEnabled] != 2) return out;
  if (next_scan_ns_ == 0) next_scan_ns_ = now_ns;
  while (next_scan_ns_ <= now_ns) {
    const auto payload = frame_payload(next_scan_ns_);
    ++frames_sent_;
    const auto item = response_read_variable(kAsyncData, reg::kReadFrame, payload);
    out.insert(out.end(), item.begin(), item.end());
    next_scan_ns_ += scan_period_ns(payload.size());
  }
  return out;
}

std::vector<std::uint8_t> SenselEmulator::read_variable(std::uint8_t r, std::int64_t now_ns) {
  std::vector<std::uint8_t> payload;
  if (r == reg::kReadFrame && regs_[reg::kScanBufferControl] > 0) {
    // Buffered: every scan completed since the last read (up to the buffer's size), oldest first,
    // each as its own variable-read answer, then 0x0A.
    std::vector<std::uint8_t> out;
    if (next_scan_ns_ == 0) next_scan_ns_ = now_ns;
    std::vector<std::vector<std::uint8_t>> scans;
    while (next_scan_ns_ <= now_ns) {
      scans.push_back(frame_payload(next_scan_ns_));
      next_scan_ns_ += scan_period_ns(scans.back().size());
    }
    const std::size_t keep = std::min<std::size_t>(scans.size(), regs_[reg::kScanBufferControl]);
    for (std::size_t i = scans.size() - keep; i < scans.size(); ++i) {  // a full buffer drops the oldest
      const auto item = response_read_variable(kRvsAck, r, scans[i]);
      out.insert(out.end(), item.begin(), item.end());
      ++frames_sent_;
    }
    out.push_back(kBufferedEnd);
    return out;
  }
  if (r == reg::kReadFrame && replay_) {  // a recorded frame, as it came; none left: no answer
    const auto& frames = replay_->pressure_frames();
    if (replay_next_ >= frames.size()) return {};
    ++frames_sent_;
    return response_read_variable(kRvsAck, r, frames[replay_next_++].payload);
  }
  if (r == reg::kReadFrame) {
    payload = frame_payload(now_ns);
    ++frames_sent_;
    auto out = response_read_variable(kRvsAck, r, payload);
    if (corrupt_next_.exchange(false)) out.back() ^= 0x5A;
    if (truncate_next_.exchange(false)) out.resize(out.size() / 2);
    return out;
  }
  if (r == reg::kSerialNumber) {
    payload.assign(16, 0xFF);
    std::memcpy(payload.data(), serial_.data(), std::min<std::size_t>(serial_.size(), 13));
  } else if (r == reg::kCompressionMetadata) {
    const Grid g = grid();
    payload = {0, 0, std::uint8_t(g.cols), std::uint8_t(g.rows), std::uint8_t(g.xscale), std::uint8_t(g.yscale)};
  } else {
    return {kRvsNack, r};
  }
  return response_read_variable(kRvsAck, r, payload);
}

std::optional<std::int64_t> SenselEmulator::replay_due(std::int64_t now_ns) {
  if (!replay_) return std::nullopt;
  const auto& frames = replay_->pressure_frames();
  if (!replay_started_) {  // the first frame read: frames due before it are not sent
    replay_started_ = true;
    replay_->start(now_ns);
    while (replay_next_ < frames.size() && replay_->due_ns(frames[replay_next_].t_ns) < now_ns) ++replay_next_;
  }
  if (replay_next_ >= frames.size()) return std::nullopt;
  return replay_->due_ns(frames[replay_next_].t_ns);
}

void SenselEmulator::replay_sent(std::int64_t asked_ns, std::int64_t woke_ns, std::int64_t host_ns) {
  if (!replay_ || !truth_ || replay_next_ == 0) return;
  const ReplayPressureFrame& f = replay_->pressure_frames()[replay_next_ - 1];
  if (f.payload.size() < 6) return;
  std::uint32_t device_us = 0;
  for (int i = 0; i < 4; ++i) device_us |= std::uint32_t(f.payload[2 + std::size_t(i)]) << (8 * i);
  *truth_ << int(f.payload[1]) << ',' << device_us << ',' << replay_->due_ns(f.t_ns) << ',' << host_ns << ','
          << asked_ns << ',' << woke_ns << '\n';
  if (++replay_logged_ % 32 == 0) truth_->flush();
}

std::vector<std::uint8_t> SenselEmulator::variable_reg(std::uint8_t address) const {
  const auto it = variable_regs_.find(address);
  return it == variable_regs_.end() ? std::vector<std::uint8_t>{} : it->second;
}

std::vector<std::uint8_t> SenselEmulator::on_host_bytes(std::span<const std::uint8_t> bytes, std::int64_t now_ns) {
  pending_.insert(pending_.end(), bytes.begin(), bytes.end());
  std::vector<std::uint8_t> out;
  std::size_t pos = 0;
  while (pending_.size() - pos >= 2) {
    if (wvs_.left > 0) {  // a WVS chunk: len_lo len_hi data chk
      const std::size_t len = std::size_t(pending_[pos]) | std::size_t(pending_[pos + 1]) << 8;
      if (len == 0 || len > kWvsMaxChunk || len > wvs_.left) {
        out.push_back(kWvsNack);
        wvs_ = {};
        pos += 2;
        continue;
      }
      if (pending_.size() - pos < 2 + len + 1) break;
      const std::span<const std::uint8_t> chunk(&pending_[pos + 2], len);
      if (checksum(chunk) != pending_[pos + 2 + len]) {
        out.push_back(kWvsNack);
        wvs_ = {};
      } else {
        wvs_.data.insert(wvs_.data.end(), chunk.begin(), chunk.end());
        wvs_.left -= std::uint32_t(len);
        if (wvs_.left == 0) variable_regs_[wvs_.reg] = std::move(wvs_.data), wvs_ = {};
        const auto ack = response_write_variable_chunk();
        out.insert(out.end(), ack.begin(), ack.end());
      }
      pos += 2 + len + 1;
      continue;
    }
    if (pending_.size() - pos < 3) break;
    const std::uint8_t board = pending_[pos], r = pending_[pos + 1], size = pending_[pos + 2];
    if (board == 0x01 && size == 0) {  // WVS header: 01 reg 00 04 n0 n1 n2 n3 chk
      if (pending_.size() - pos < 9) break;
      const std::span<const std::uint8_t> n(&pending_[pos + 4], 4);
      const std::uint32_t total =
          std::uint32_t(n[0]) | std::uint32_t(n[1]) << 8 | std::uint32_t(n[2]) << 16 | std::uint32_t(n[3]) << 24;
      if (pending_[pos + 3] != 4 || checksum(n) != pending_[pos + 8] || total == 0 || total > 65536) {
        out.push_back(kWvsNack);
        out.push_back(r);
      } else {
        wvs_ = {r, total, {}};
        const auto ack = response_write_variable_header(r);
        out.insert(out.end(), ack.begin(), ack.end());
      }
      pos += 9;
      continue;
    }
    if (board == 0x81) {  // read
      std::vector<std::uint8_t> answer =
          size == 0 ? read_variable(r, now_ns)
                    : response_read(r, std::span<const std::uint8_t>(&regs_[r], std::min<std::size_t>(size, 256u - r)));
      out.insert(out.end(), answer.begin(), answer.end());
      pos += 3;
    } else if (board == 0x01) {  // write: 01 reg size data chk
      if (pending_.size() - pos < 3u + size + 1u) break;
      const std::span<const std::uint8_t> data(&pending_[pos + 3], size);
      if (checksum(data) != pending_[pos + 3 + size]) {
        out.push_back(kWriteNack);
        out.push_back(r);
      } else {
        if (r == reg::kSoftReset && size >= 1 && data[0] == 1)
          soft_reset();
        else if (r == reg::kScanEnabled) {
          regs_[r] = data[0];
          next_scan_ns_ = 0;  // scanning (re)starts now
          if (data[0] != 0 && revert_detail_on_start_) regs_[reg::kScanDetail] = 1;
        } else if (r == ignored_reg_)
          ;  // acknowledged, not taken
        else
          for (std::size_t i = 0; i < size && r + i < 256; ++i) regs_[r + i] = data[i];
        const auto ack = response_write(r);
        out.insert(out.end(), ack.begin(), ack.end());
      }
      pos += 3u + size + 1u;
    } else {
      ++pos;  // not a command start: resynchronise on the next byte
    }
  }
  pending_.erase(pending_.begin(), pending_.begin() + std::ptrdiff_t(pos));
  return out;
}

}  // namespace pvcap::sim
