// libFuzzer target: the host's PTP state parser reads what linuxptp's pmc printed (sync/ptp_host.h),
// which is whatever ptp4l or another program behind its socket answered. For any text it gives a
// state or an Error saying why, never crashes, and a state it gives is judged without trouble.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "sync/ptp_host.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const auto s = pvcap::sync::parse_pmc_answer(text);
  if (!s) {
    if (s.error().message.empty()) __builtin_trap();  // an Error always says why
    return 0;
  }
  if (!std::isfinite(s.value().offset_ns) || !std::isfinite(s.value().path_delay_ns)) __builtin_trap();
  if (s.value().steps_removed < 0 || s.value().steps_removed > 255) __builtin_trap();
  (void)pvcap::sync::ptp_host_out_of_time(s.value(), 1000);
  (void)pvcap::sync::describe(s.value());
  return 0;
}
