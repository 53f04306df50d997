#pragma once
// The simulated rig needs one IP address per camera. Rather than touching the
// host's network, pvcap moves itself into a private network namespace whose
// loopback carries 127.0.0.1 plus the cameras' 127.0.0.x addresses. Nothing in
// it is reachable from outside; the host's interfaces are not visible in it.
#include <string>
#include <vector>

#include "core/result.h"

namespace pvcap::sim {

// Unshares the network namespace of the calling thread (call it before any other
// thread starts: threads created later inherit it), brings loopback up and adds
// `addresses` (each 127.x.y.z). Needs root or CAP_SYS_ADMIN + CAP_NET_ADMIN.
Status enter_private_network(const std::vector<std::string>& addresses);

// True when this process already runs in a namespace that holds all `addresses`.
bool addresses_present(const std::vector<std::string>& addresses);

}  // namespace pvcap::sim
