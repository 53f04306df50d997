#include "capture/device_listing.h"

#include <iterator>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

namespace pvcap {

std::string device_listing(const std::vector<DiscoveredCamera>& cams, const std::vector<sensel::FoundSensel>& sensels,
                           bool json) {
  std::string out;
  auto to = std::back_inserter(out);
  // One object per line, its fields in this order; names from the wire escaped (bytes that are not
  // UTF-8 replaced: a camera may send any).
  if (json) {
    for (const auto& c : cams)
      out += nlohmann::ordered_json{{"kind", "camera"},     {"vendor", c.vendor},   {"model", c.model},
                                    {"serial", c.serial},   {"address", c.address}, {"interface", c.protocol},
                                    {"mac", c.physical_id}, {"id", c.device_id}}
                 .dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace) +
             "\n";
    for (const auto& s : sensels)
      out +=
          nlohmann::ordered_json{
              {"kind", "sensel"}, {"serial", s.info.serial},    {"firmware", s.info.firmware},
              {"tty", s.tty},     {"usb_serial", s.usb_serial}, {"grid", {s.info.grid.cols, s.info.grid.rows}}}
              .dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace) +
          "\n";
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
