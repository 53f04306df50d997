#pragma once
// `pvcap devices`: the GigE Vision cameras that answer discovery and the Sensel Morphs on a tty
// or the USB bus (read without resetting them), as a table or one JSON object per line.
#include <string>
#include <vector>

namespace pvcap {

// `extra_ttys`: serial ports to try besides /dev/ttyACM* and /dev/morph* (a simulated rig's).
int cmd_devices(bool json, const std::vector<std::string>& extra_ttys);

}  // namespace pvcap
