#pragma once
// How bytes reach a Sensel Morph. Two transports behind one interface: a tty
// (/dev/ttyACM*, or the emulator's pseudo-terminal) and libusb on the Morph's
// bulk endpoints. read() waits at most `timeout_ms`; 0 bytes means nothing arrived in
// time; an Error means the device is gone (unplugged, hung up).
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/result.h"

namespace pvcap::sensel {

class Transport {
 public:
  virtual ~Transport() = default;
  virtual Status write(std::span<const std::uint8_t> bytes) = 0;
  virtual Result<std::size_t> read(std::span<std::uint8_t> into, int timeout_ms) = 0;
  virtual std::string describe() const = 0;  // for messages: "tty /dev/ttyACM0"
};

// Opens a tty in raw mode at 115200 8N1 (nominal on USB CDC).
Result<std::unique_ptr<Transport>> open_tty(const std::string& path);
// Serial ports in `dir` a Morph may be behind, sorted: cdc_acm's ttyACM*, and names containing
// "morph" (a udev rule's /dev/morph*; the Sensel SDK scans for the same names).
std::vector<std::string> sensel_tty_candidates(const std::filesystem::path& dir = "/dev");

// Opens the Morph (USB 2c2f:0003) whose USB serial string is `usb_serial` ("" = the only
// one on the bus): detaches cdc_acm from interfaces 0 and 1, claims interface 1.
Result<std::unique_ptr<Transport>> open_usb(const std::string& usb_serial);
// The USB serials of the Morphs on the bus (or, for one that cannot be opened, why).
Result<std::vector<std::string>> list_usb_sensels();

}  // namespace pvcap::sensel
