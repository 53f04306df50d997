#include "capture/sensel_discovery.h"

#include <algorithm>

#include <fmt/format.h>

namespace pvcap::sensel {

SenselListing list_sensels(const std::vector<std::string>& extra_ttys) {
  SenselListing out;
  std::vector<std::string> ttys = extra_ttys;
  for (auto& path : sensel_tty_candidates("/dev")) ttys.push_back(std::move(path));
  for (const auto& path : ttys) {
    auto t = open_tty(path);
    if (!t) {
      // A Morph a session streams from is locked: listed as busy, never probed (that would reset it).
      if (t.error().message.find("in use by another pvcap") != std::string::npos)
        out.notes.push_back(fmt::format("Sensel Morph on {}: in use by a running pvcap session (not touched)", path));
      continue;
    }
    if (auto info = SenselDevice::probe(std::move(t.value()))) out.found.push_back({path, "", info.value()});
  }
  // Morphs reachable over libusb: the same device as a /dev/ttyACM one is listed once, with both.
  auto usb = list_usb_sensels();
  if (!usb) return out;
  for (const auto& serial : usb.value()) {
    if (serial.find('/') != std::string::npos) {  // cannot be opened: the entry says why
      out.notes.push_back(fmt::format("Sensel Morph {}", serial));
      continue;
    }
    auto t = open_usb(serial);
    if (!t) {
      // Held by another program (a running session): named, and left alone as a locked tty is.
      if (t.error().message.find("another program has it open") != std::string::npos)
        out.notes.push_back(
            fmt::format("Sensel Morph {} over USB: in use by another program, such as a running "
                        "pvcap session (not touched)",
                        serial.empty() ? "(no USB serial)" : serial));
      continue;
    }
    auto info = SenselDevice::probe(std::move(t.value()));
    if (!info) continue;
    auto same = std::find_if(out.found.begin(), out.found.end(),
                             [&](const FoundSensel& s) { return s.info.serial == info.value().serial; });
    if (same != out.found.end())
      same->usb_serial = serial;
    else
      out.found.push_back({"", serial, info.value()});
  }
  return out;
}

}  // namespace pvcap::sensel
