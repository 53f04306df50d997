#include "app/cmd_devices.h"

#include <algorithm>
#include <filesystem>

#include <fmt/format.h>

#include "capture/aravis_discovery.h"
#include "capture/sensel_device.h"

namespace pvcap {

namespace {

// Serial ports a Sensel Morph may be behind: /dev's candidates, and extra paths.
std::vector<std::string> sensel_candidates(const std::vector<std::string>& extra) {
  std::vector<std::string> out = extra;
  for (auto& path : sensel::sensel_tty_candidates("/dev")) out.push_back(std::move(path));
  return out;
}

}  // namespace

int cmd_devices(bool json, const std::vector<std::string>& extra_ttys) {
  const auto cams = discover_gige_cameras();
  struct FoundSensel {
    std::string path;        // tty, if one answered
    std::string usb_serial;  // USB serial string, if reachable over libusb
    sensel::SenselInfo info;
  };
  std::vector<FoundSensel> sensels;
  for (const auto& path : sensel_candidates(extra_ttys)) {
    auto t = sensel::open_tty(path);
    if (!t) {
      // A Morph a session streams from is locked: listed as busy, never probed (that would reset it).
      if (t.error().message.find("in use by another pvcap") != std::string::npos)
        fmt::print(stderr, "Sensel Morph on {}: in use by a running pvcap session (not touched)\n", path);
      continue;
    }
    if (auto info = sensel::SenselDevice::probe(std::move(t.value()))) sensels.push_back({path, "", info.value()});
  }
  // Morphs reachable over libusb: the same device as a /dev/ttyACM one is listed once, with both.
  if (auto usb = sensel::list_usb_sensels(); usb) {
    for (const auto& serial : usb.value()) {
      if (serial.find('/') != std::string::npos) {  // cannot be opened: says why
        fmt::print(stderr, "Sensel Morph {}\n", serial);
        continue;
      }
      auto t = sensel::open_usb(serial);
      if (!t) continue;  // e.g. held by a running session
      auto info = sensel::SenselDevice::probe(std::move(t.value()));
      if (!info) continue;
      auto same = std::find_if(sensels.begin(), sensels.end(),
                               [&](const FoundSensel& s) { return s.info.serial == info.value().serial; });
      if (same != sensels.end()) same->usb_serial = serial;
      else sensels.push_back({"", serial, info.value()});
    }
  }
  if (json) {
    for (const auto& c : cams)
      fmt::print("{{\"kind\":\"camera\",\"vendor\":\"{}\",\"model\":\"{}\",\"serial\":\"{}\",\"address\":\"{}\","
                 "\"interface\":\"{}\",\"mac\":\"{}\",\"id\":\"{}\"}}\n",
                 c.vendor, c.model, c.serial, c.address, c.protocol, c.physical_id, c.device_id);
    for (const auto& s : sensels)
      fmt::print("{{\"kind\":\"sensel\",\"serial\":\"{}\",\"firmware\":\"{}\",\"tty\":\"{}\",\"usb_serial\":\"{}\","
                 "\"grid\":[{},{}]}}\n",
                 s.info.serial, s.info.firmware, s.path, s.usb_serial, s.info.grid.cols, s.info.grid.rows);
    return 0;
  }
  if (cams.empty())
    fmt::print("no GigE Vision camera answered discovery (check power, cabling, and that the cameras are on a "
               "subnet of one of this machine's interfaces)\n");
  else {
    fmt::print("{:<10} {:<14} {:<14} {:<16} {:<12} {}\n", "interface", "vendor", "model", "serial", "address", "mac");
    for (const auto& c : cams)
      fmt::print("{:<10} {:<14} {:<14} {:<16} {:<12} {}\n", c.protocol, c.vendor, c.model, c.serial, c.address,
                 c.physical_id);
  }
  if (sensels.empty())
    fmt::print("no Sensel Morph answered on /dev/ttyACM*, /dev/morph* or USB 2c2f:0003 (check the cable; the "
               "user needs the dialout group or a udev rule)\n");
  else
    for (const auto& s : sensels) {
      std::string where = s.path;
      if (!s.usb_serial.empty()) where += (where.empty() ? "" : ", ") + fmt::format("usb: {}", s.usb_serial);
      fmt::print("{:<10} {:<14} {:<14} {:<16} {:<12} firmware {}, grid {}x{}\n", "sensel", "Sensel", "Morph",
                 s.info.serial, where, s.info.firmware, s.info.grid.cols, s.info.grid.rows);
    }
  return 0;
}

}  // namespace pvcap
