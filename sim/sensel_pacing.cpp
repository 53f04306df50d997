#include "sim/sensel_pacing.h"

#include <algorithm>

#include "codec/sensel_protocol.h"

namespace pvcap::sim {

SenselPacer::SenselPacer(SenselEmulator& emulator, SenselLink link)
    : emu_(emulator),
      link_(link),
      rng_(link.seed),
      usb_delay_ms_(link.jitter_mean_ms > 0 ? 1.0 / link.jitter_mean_ms : 1.0) {}

PacedAnswer SenselPacer::answer(std::span<const std::uint8_t> request, std::int64_t now_ns) {
  // A sync frame read (`81 26 00`); buffered reads return what is already due.
  const bool frame_read = request.size() >= 3 && request[0] == 0x81 && request[1] == sensel::reg::kReadFrame &&
                          request[2] == 0 && emu_.reg(sensel::reg::kScanBufferControl) == 0;
  if (!frame_read) return {emu_.on_host_bytes(request, now_ns), now_ns};
  if (emu_.replaying()) {  // a recorded frame leaves when it is due (no scan, no added USB delay)
    const auto due = emu_.replay_due(now_ns);
    // Not due for a while (a gap in the recording, or its end): this request goes unanswered, as
    // on a device that stalls; an answer held past the driver's timeout would answer its next one.
    if (!due || *due > now_ns + kReplayHoldNs) return {{}, now_ns, false};
    const std::int64_t at = std::max(now_ns, *due);
    return {emu_.on_host_bytes(request, at), at, true};
  }

  const std::int64_t scan_ns = std::max(next_scan_ns_, now_ns);
  PacedAnswer a{emu_.on_host_bytes(request, scan_ns), scan_ns};
  const bool high = emu_.grid() == sensel::kHighDetail;
  const std::int64_t period_ns = high ? 19'600'000 + std::int64_t(12'500.0 * double(a.bytes.size())) : 8'000'000;
  next_scan_ns_ = scan_ns + period_ns;
  if (link_.jitter_mean_ms > 0)
    a.deliver_at_ns += std::int64_t(std::min(usb_delay_ms_(rng_), link_.jitter_max_ms) * 1e6);
  return a;
}

}  // namespace pvcap::sim
