// libFuzzer target: the spill reader reads files a crash may have cut anywhere, or a disk may have
// damaged (`pvcap recover` and `pvcap verify` read them). For any bytes it returns the records it
// could read whole or an error, never reads past the file, and every record it hands out is an
// image of the size its header says.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>

#include "storage/writer/frame_spill.h"
#include "tests/fuzz/fuzz_scratch.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = (pvcap::fuzz::scratch("spill") / "input.spill").string();
  if (FILE* f = std::fopen(path.c_str(), "wb")) {
    if (size) std::fwrite(data, 1, size, f);
    std::fclose(f);
  } else {
    return 0;
  }
  std::size_t handed = 0;
  auto n = pvcap::read_spill_file(path, [&](pvcap::SpillRecord&& r) {
    ++handed;
    if (r.image.empty() || r.image.total() * r.image.elemSize() > size) __builtin_trap();  // more than was there
  });
  if (n && n.value() != handed) __builtin_trap();
  if (!n && n.error().message.empty()) __builtin_trap();  // an error always says why
  return 0;
}
