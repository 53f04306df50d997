#pragma once
// The Sensel Morphs this machine can reach, on a serial port or over libusb, each
// asked for its serial, firmware and grid without a reset (what `pvcap devices`
// lists). A Morph a running pvcap streams from is named as busy and not touched.
#include <string>
#include <vector>

#include "capture/sensel_device.h"

namespace pvcap::sensel {

struct FoundSensel {
  std::string tty;         // the serial port it answered on, if any
  std::string usb_serial;  // its USB serial string, if reachable over libusb
  SenselInfo info;
};

struct SenselListing {
  std::vector<FoundSensel> found;  // one entry per Morph (a tty and USB view of one device merged)
  std::vector<std::string> notes;  // Morphs seen but not asked: busy, or not openable (with why)
};

// `extra_ttys`: serial ports to try besides /dev/ttyACM* and /dev/morph* (a simulated rig's).
SenselListing list_sensels(const std::vector<std::string>& extra_ttys);

}  // namespace pvcap::sensel
