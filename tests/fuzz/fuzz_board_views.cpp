// libFuzzer target: a board views file's parser (what `pvcap calibrate intrinsics --save-views`
// writes, and a lab may send) turns any bytes into views whose ids and corners pair up, or an Error
// naming the file; never a crash or an exception.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "calib/board_views_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string source = "fuzz.board-views.yaml";
  auto parsed = pvcap::calib::parse_board_views(std::string(reinterpret_cast<const char*>(data), size), source);
  if (!parsed) {
    if (parsed.error().message.rfind(source, 0) != 0) __builtin_trap();  // every error names the file
    return 0;
  }
  if (parsed.value().image_size.width < 1 || parsed.value().image_size.height < 1) __builtin_trap();
  for (const auto& v : parsed.value().views) {
    if (v.ids.size() != v.corners.size()) __builtin_trap();
    for (const auto& p : v.corners)
      if (!std::isfinite(p.x) || !std::isfinite(p.y)) __builtin_trap();
  }
  return 0;
}
