// libFuzzer target: Sensel capture files (what `pvcap sensel decode` reads: the recorder's .json or
// .jsonl wire dumps). The first byte picks the file's kind, the rest is the file. Any bytes give a
// summary or an Error naming the file; a summary accounts for every frame (decoded or rejected with
// a reason) and its figures are finite. Never a crash, a hang or an exception.
#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "codec/sensel_capture_file.h"
#include "tests/fuzz/fuzz_scratch.h"

namespace {
const std::filesystem::path& scratch() { return pvcap::fuzz::scratch("capture"); }
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const auto path = scratch() / ((data[0] & 1) ? "capture.jsonl" : "capture.json");
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data + 1), std::streamsize(size - 1));
  const auto s = pvcap::sensel::summarise_capture_file(path);
  if (!s) {
    if (s.error().message.rfind(path.string() + ":", 0) != 0) __builtin_trap();  // names the file
    return 0;
  }
  const auto& v = s.value();
  std::size_t rejected = 0;
  for (const auto& [why, n] : v.rejected) {
    if (why.empty() || n == 0) __builtin_trap();
    rejected += n;
  }
  if (v.decoded + rejected != v.frames) __builtin_trap();
  if (rejected > 0 && v.first_rejection.empty()) __builtin_trap();
  for (const double x : {v.span_s, v.peak_cell_g, v.peak_cell_kpa, v.peak_total_g})
    if (!std::isfinite(x) || x < 0) __builtin_trap();
  if (v.peak_total_g + 1e-9 < v.peak_cell_g) __builtin_trap();
  return 0;
}
