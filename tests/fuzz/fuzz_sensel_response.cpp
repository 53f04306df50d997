// libFuzzer target: the Sensel command-response parser reads bytes from the device (or whatever
// sits behind the tty). For any bytes and any expected response it says NeedMore, Ok or Bad with
// a reason, never reads past the input, and always lets the caller make progress.
#include <cstddef>
#include <cstdint>
#include <span>

#include "codec/sensel_protocol.h"

using namespace pvcap::sensel;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 3) return 0;
  const auto expect = static_cast<Expect>(data[0] % 5);
  const std::uint8_t reg = data[1], want = data[2];
  std::span<const std::uint8_t> bytes(data + 3, size - 3);
  // Parse the stream as the driver does: response after response, skipping what is Bad.
  for (int guard = 0; guard < 100000 && !bytes.empty(); ++guard) {
    const Response r = parse_response(bytes, expect, reg, want);
    if (r.state == Response::State::NeedMore) break;
    if (r.consumed == 0 || r.consumed > bytes.size()) __builtin_trap();        // no progress, or past the end
    if (r.state == Response::State::Bad && r.error.empty()) __builtin_trap();  // a Bad always says why
    if (r.state == Response::State::Ok && r.data.size() > bytes.size()) __builtin_trap();
    bytes = bytes.subspan(r.consumed);
  }
  return 0;
}
