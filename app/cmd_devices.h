#pragma once
// `pvcap devices`: the GigE Vision cameras that answer discovery and the Sensel Morphs on a tty
// or the USB bus (read without resetting them), as a table or one JSON object per line.
#include <string>
#include <vector>

#include "core/rig_config.h"

namespace pvcap {

// `extra_ttys`: serial ports to try besides /dev/ttyACM* and /dev/morph* (a simulated rig's).
int cmd_devices(bool json, const std::vector<std::string>& extra_ttys);
// The same, with the simulated `rig` started first (in this process' network, already made).
int cmd_devices_of_sim(bool json, const RigConfig& rig);

}  // namespace pvcap
