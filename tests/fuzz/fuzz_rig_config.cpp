// libFuzzer target: the rig-config parser (and the simulator's reader of its sim: section) must
// turn any bytes into either a rig or a UserError with a message; never a crash, a hang, or another
// exception.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/result.h"
#include "core/rig_config.h"
#include "sim/sim_config.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const pvcap::RigConfig rig = pvcap::parse_rig_config(text, "fuzz.yaml");
    if (rig.cameras.empty()) __builtin_trap();  // the parser promised at least one camera
    const auto sim = pvcap::sim::load_sim_config(rig);
    if (rig.simulated != sim.has_value()) __builtin_trap();
    if (sim && sim->cameras.size() != rig.cameras.size()) __builtin_trap();  // one entry per camera
  } catch (const pvcap::UserError& e) {
    if (std::string(e.what()).rfind("fuzz.yaml:", 0) != 0) __builtin_trap();  // every error names file:line
  }
  return 0;
}
