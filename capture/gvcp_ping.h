#pragma once
// Asks a GigE Vision camera whether it is there: one GVCP READREG of its bootstrap Version
// register (0x0000) over UDP port 3956, from a socket of its own. Any application may read a
// camera's registers (monitor access), so this does not disturb the controlling connection; and
// unlike a read through Aravis (5 tries of 500 ms before it fails) it gives up when told.
// Used for a camera on a trigger line, which may rightly send nothing for a while.
// Also the GVCP command no library here sends: ACTION_CMD (scheduled actions across hosts,
// docs/multihost.md), to each camera from the same kind of socket.
#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "capture/gige_vision_wire.h"
#include "core/result.h"

namespace pvcap {

// True when the camera at `ipv4` acknowledged the read within `timeout`.
bool gvcp_answers(const std::string& ipv4, std::chrono::milliseconds timeout);
// What one device said to an action command.
struct ActionAnswer {
  std::string address;
  bool acknowledged = false;  // an ACTION_ACK came within the wait
  std::uint16_t status = 0;   // its status: 0 success; an error otherwise, e.g. gev::kGvcpStatusActionLate
};
// Sends `action` to each address (its GVCP port, `port` for a test's device) from one socket, asking
// for an acknowledge, and waits up to `wait` for them; an Error only when nothing could be sent.
Result<std::vector<ActionAnswer>> send_action_command(const std::vector<std::string>& addresses,
                                                      const gev::ActionCommand& action,
                                                      std::chrono::milliseconds wait,
                                                      std::uint16_t port = gev::kGvcpPort);
// Whether `address` is a dotted IPv4 address (a GigE Vision camera's; a USB3 Vision one has none).
bool is_ipv4(const std::string& address);

}  // namespace pvcap
