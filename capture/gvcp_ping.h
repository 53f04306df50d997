#pragma once
// Asks a GigE Vision camera whether it is there: one GVCP READREG of its bootstrap Version
// register (0x0000) over UDP port 3956, from a socket of its own. Any application may read a
// camera's registers (monitor access), so this does not disturb the controlling connection; and
// unlike a read through Aravis (5 tries of 500 ms before it fails) it gives up when told.
// Used for a camera on a trigger line, which may rightly send nothing for a while.
#include <chrono>
#include <string>

namespace pvcap {

// True when the camera at `ipv4` acknowledged the read within `timeout`.
bool gvcp_answers(const std::string& ipv4, std::chrono::milliseconds timeout);
// Whether `address` is a dotted IPv4 address (a GigE Vision camera's; a USB3 Vision one has none).
bool is_ipv4(const std::string& address);

}  // namespace pvcap
