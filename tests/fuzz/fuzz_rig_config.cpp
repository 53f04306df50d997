// libFuzzer target: the rig-config parser must turn any bytes into either a rig or a
// UserError with a message; never a crash, a hang, or another exception.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/result.h"
#include "core/rig_config.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const pvcap::RigConfig rig = pvcap::parse_rig_config(text, "fuzz.yaml");
    if (rig.cameras.empty()) __builtin_trap();  // the parser promised at least one camera
  } catch (const pvcap::UserError& e) {
    if (std::string(e.what()).rfind("fuzz.yaml:", 0) != 0) __builtin_trap();  // every error names file:line
  }
  return 0;
}
