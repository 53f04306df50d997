#pragma once
// `pvcap devices`: the GigE Vision cameras that answer discovery and the Sensel Morphs on a tty
// or the USB bus (read without resetting them), as a table or one JSON object per line; or one
// camera's node map, written to a file.
#include <functional>
#include <string>
#include <vector>

#include "core/rig_config.h"

namespace pvcap {

// `extra_ttys`: serial ports to try besides /dev/ttyACM* and /dev/morph* (a simulated rig's).
int cmd_devices(bool json, const std::vector<std::string>& extra_ttys);
// The same, with the simulated `rig` started first (in this process' network, already made);
// `with_devices`, when given, runs instead of the listing while the simulated devices are up.
int cmd_devices_of_sim(bool json, const RigConfig& rig, const std::function<int()>& with_devices = {});
// Writes a reachable camera's GenICam XML to `out` (`pvcap devices --dump-node-map`).
int dump_node_map(const std::string& camera, const std::string& out);

}  // namespace pvcap
