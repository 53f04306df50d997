#pragma once
// Which GigE Vision cameras answer discovery (for `pvcap devices`).
#include <string>
#include <vector>

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

}  // namespace pvcap
