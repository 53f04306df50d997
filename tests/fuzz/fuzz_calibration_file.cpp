// libFuzzer target: a rig calibration file's parser turns any bytes into either a calibration whose
// cameras have usable models, or an Error naming the file; never a crash or an exception.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "calib/rig_calibration.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string source = "fuzz.calibration.yaml";
  auto parsed = pvcap::calib::parse_rig_calibration(std::string(reinterpret_cast<const char*>(data), size), source);
  if (!parsed) {
    if (parsed.error().message.rfind(source, 0) != 0) __builtin_trap();  // every error names the file
    return 0;
  }
  for (const auto& c : parsed.value().cameras) {
    if (c.model.image_size.width < 1 || c.model.K(0, 0) <= 0) __builtin_trap();
    (void)c.model.centre_mm();
  }
  return 0;
}
