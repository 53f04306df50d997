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

Result<std::string> read_node_map(const std::string& camera) {
  const auto cams = discover_gige_cameras();
  const DiscoveredCamera* found = nullptr;
  std::string names;
  for (const auto& c : cams) {
    if (c.serial == camera || c.address == camera || c.device_id == camera) found = &c;
    names += (names.empty() ? "" : ", ") + c.serial + " (" + c.address + ")";
  }
  if (!found)
    return Error{"no camera " + camera + " answered discovery" +
                 (names.empty() ? std::string(" (none did)") : " (those that did: " + names + ")")};
  arv::GErrorSlot err;
  arv::GPtr<ArvDevice> device(arv_open_device(found->device_id.c_str(), err.out()));
  if (!device) return Error{"camera " + camera + " could not be opened: " + err.message()};
  std::size_t size = 0;
  const char* xml = arv_device_get_genicam_xml(device.get(), &size);
  if (!xml || size == 0) return Error{"camera " + camera + " gave no node map"};
  return std::string(xml, size);
}

}  // namespace pvcap
