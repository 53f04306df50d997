// libFuzzer target: a protocol file's parser turns any bytes into either a protocol whose plan
// can be made, or a UserError naming file:line; never a crash, a hang, or another exception.
#include <cstddef>
#include <cstdint>
#include <set>
#include <string>

#include "core/result.h"
#include "protocol/protocol.h"

#define PVCAP_STRINGIFY2(x) #x
#define PVCAP_STRINGIFY(x) PVCAP_STRINGIFY2(x)

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // Beside the shipped protocols, so that their pictogram paths (the seeds') resolve.
  const std::string source = PVCAP_STRINGIFY(PVCAP_PROTOCOLS_DIR) "/fuzz.yaml";
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const auto p = pvcap::protocol::parse_protocol(text, source);
    if (p.actions.empty()) __builtin_trap();
    std::set<std::string> names;
    for (const auto& a : p.actions) {
      if (a.repetitions < 1 || a.repetitions > 100 || !names.insert(a.name).second) __builtin_trap();
      if (a.timings.record_s <= 0) __builtin_trap();
    }
    const auto plan = pvcap::protocol::make_plan(p, "left_first");
    std::size_t takes = 0;
    for (const auto& a : p.actions) {
      if (!a.left_hand && !a.right_hand) __builtin_trap();  // an action no hand performs
      takes += std::size_t(a.left_hand) + std::size_t(a.right_hand);
    }
    if (plan.size() != takes) __builtin_trap();
    for (const auto& t : plan)
      if (t.sequence_name(2).empty()) __builtin_trap();
  } catch (const pvcap::UserError& e) {
    if (std::string(e.what()).rfind(source + ":", 0) != 0) __builtin_trap();  // every error names file:line
  }
  return 0;
}
