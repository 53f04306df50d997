#include "capture/device_listing.h"

#include <iterator>

#include <fmt/format.h>

namespace pvcap {

std::string device_listing(const std::vector<DiscoveredCamera>& cams, const std::vector<sensel::FoundSensel>& sensels,
                           bool json) {
  std::string out;
  auto to = std::back_inserter(out);
  if (json) {
    for (const auto& c : cams)
      fmt::format_to(to,
                     "{{\"kind\":\"camera\",\"vendor\":\"{}\",\"model\":\"{}\",\"serial\":\"{}\",\"address\":\"{}\","
                     "\"interface\":\"{}\",\"mac\":\"{}\",\"id\":\"{}\"}}\n",
                     c.vendor, c.model, c.serial, c.address, c.protocol, c.physical_id, c.device_id);
    for (const auto& s : sensels)
      fmt::format_to(to,
                     "{{\"kind\":\"sensel\",\"serial\":\"{}\",\"firmware\":\"{}\",\"tty\":\"{}\",\"usb_serial\":\"{}\","
                     "\"grid\":[{},{}]}}\n",
                     s.info.serial, s.info.firmware, s.tty, s.usb_serial, s.info.grid.cols, s.info.grid.rows);
    return out;
  }
  if (cams.empty())
    fmt::format_to(to,
                   "no GigE Vision camera answered discovery (check power, cabling, and that the cameras are on a "
                   "subnet of one of this machine's interfaces)\n");
  else {
    fmt::format_to(to, "{:<10} {:<14} {:<14} {:<16} {:<12} {}\n", "interface", "vendor", "model", "serial", "address",
                   "mac");
    for (const auto& c : cams)
      fmt::format_to(to, "{:<10} {:<14} {:<14} {:<16} {:<12} {}\n", c.protocol, c.vendor, c.model, c.serial, c.address,
                     c.physical_id);
  }
  if (sensels.empty())
    fmt::format_to(to,
                   "no Sensel Morph answered on /dev/ttyACM*, /dev/morph* or USB 2c2f:0003 (check the cable; the "
                   "user needs the dialout group or a udev rule)\n");
  else
    for (const auto& s : sensels) {
      std::string where = s.tty;
      if (!s.usb_serial.empty()) where += (where.empty() ? "" : ", ") + fmt::format("usb: {}", s.usb_serial);
      fmt::format_to(to, "{:<10} {:<14} {:<14} {:<16} {:<12} firmware {}, grid {}x{}\n", "sensel", "Sensel", "Morph",
                     s.info.serial, where, s.info.firmware, s.info.grid.cols, s.info.grid.rows);
    }
  return out;
}

}  // namespace pvcap
