#include "capture/aravis_discovery.h"

#include <arv.h>

#include "capture/aravis_handles.h"

namespace pvcap {

std::vector<DiscoveredCamera> discover_gige_cameras() {
  arv::route_glib_logs_to_spdlog();
  arv_update_device_list();
  std::vector<DiscoveredCamera> out;
  const unsigned n = arv_get_n_devices();
  auto str = [](const char* s) { return std::string(s ? s : ""); };
  for (unsigned i = 0; i < n; ++i) {
    DiscoveredCamera c{str(arv_get_device_id(i)),      str(arv_get_device_vendor(i)),
                       str(arv_get_device_model(i)),   str(arv_get_device_serial_nbr(i)),
                       str(arv_get_device_address(i)), str(arv_get_device_physical_id(i)),
                       str(arv_get_device_protocol(i))};
    if (c.protocol == "GigEVision") out.push_back(std::move(c));
  }
  return out;
}

}  // namespace pvcap
