#pragma once
// Which GigE Vision cameras answer discovery (for `pvcap devices`).
#include <string>
#include <vector>

#include "core/result.h"

namespace pvcap {

struct DiscoveredCamera {
  std::string device_id;  // Aravis' id, usable to open it
  std::string vendor;
  std::string model;
  std::string serial;
  std::string address;      // IPv4 of the camera
  std::string physical_id;  // MAC address
  std::string protocol;     // "GigEVision"
};

std::vector<DiscoveredCamera> discover_gige_cameras();

// A reachable camera's GenICam node map (its XML), for `pvcap devices --dump-node-map`: the camera
// named by serial, address or Aravis id. An Error says which cameras there are when none matches.
Result<std::string> read_node_map(const std::string& camera);

}  // namespace pvcap
