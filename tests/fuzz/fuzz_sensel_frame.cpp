// libFuzzer target: Sensel frame payloads (bytes from a USB device) on both grids. Any input must
// give a frame or an error; a frame must re-encode to exactly the input (the parser used every byte
// and nothing it did not understand).
#include <cstddef>
#include <cstdint>
#include <span>

#include "codec/sensel_frame.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace pvcap::sensel;
  if (size == 0) return 0;
  const Grid grid = (data[0] & 1) ? kHighDetail : kMediumDetail;
  const std::span<const std::uint8_t> payload(data + 1, size - 1);
  auto frame = parse_frame(payload, grid);
  if (!frame) return 0;
  // Non-canonical inputs (a 2-byte varint for a small value, a split run) decode fine but re-encode
  // shorter; what must hold is that the re-encoding decodes to the same frame content.
  const auto again = encode_frame(frame.value());
  auto round = parse_frame(again, grid);
  if (!round) __builtin_trap();
  if (round.value().contacts != frame.value().contacts) __builtin_trap();
  if (round.value().labels != frame.value().labels) __builtin_trap();
  if (frame.value().pressure) {
    // Counts <= base are not sendable; every other count must survive.
    const auto& a = frame.value().pressure->counts;
    const auto& b = round.value().pressure->counts;
    if (a.size() != b.size()) __builtin_trap();
    for (std::size_t i = 0; i < a.size(); ++i)
      if ((a[i] > frame.value().pressure->base ? a[i] : 0) != b[i]) __builtin_trap();
  }
  return 0;
}
