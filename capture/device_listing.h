#pragma once
// What `pvcap devices` shows of the devices found: a table (with what to check when none answered),
// or one JSON object per device and line.
#include <string>
#include <vector>

#include "capture/aravis_discovery.h"
#include "capture/sensel_discovery.h"

namespace pvcap {

std::string device_listing(const std::vector<DiscoveredCamera>& cameras,
                           const std::vector<sensel::FoundSensel>& sensels, bool json);

}  // namespace pvcap
