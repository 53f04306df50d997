#pragma once
// A Sensel Morph on an emulated USB bus, for the driver's libusb transport.
//
// umockdev's testbed provides the device as the kernel would: a sysfs entry with
// the Morph's identity and binary descriptors (what libusb enumerates), and a
// /dev/bus/usb node whose usbdevfs ioctls land in our handler. The handler is a
// small usbdevfs: cdc_acm bound to interfaces 0 and 1 until the host detaches it
// (claiming a bound interface fails with EBUSY, as on Linux), string descriptors
// over control transfers, and bulk URBs on 0x02/0x82 carried to the emulator,
// answers paced by SenselPacer. A test can stall the device, unplug it and plug
// it back in (at a new address, as a real re-enumeration gives).
//
// The host is this process (a driver test), started under umockdev's preload library
// (LD_PRELOAD=libumockdev-preload.so.0, what umockdev-wrapper sets; create() says so
// otherwise), or other processes (a simulated rig's recording): they run under the
// preload with UMOCKDEV_DIR set to root_dir(), and their ioctls reach the handler here
// over umockdev's socket (several round trips per transfer: about a third of a core
// at the Morph's 125 Hz; docs/testing.md).
#include <memory>
#include <string>

#include "core/result.h"
#include "sim/sensel_emulator.h"
#include "sim/sensel_pacing.h"

namespace pvcap::sim {

struct SenselUsbIdentity {
  std::string serial = "2044B8374E33";  // the USB serial string (not register 0x0F's)
  std::string manufacturer = "Sensel";
  std::string product = "Sensel Morph";
};

enum class SenselUsbHost { ThisProcess, OtherProcesses };

class SenselUsbDevice {
 public:
  static Result<std::unique_ptr<SenselUsbDevice>> create(SenselEmulator& emulator, SenselLink link = {},
                                                         SenselUsbIdentity identity = {},
                                                         SenselUsbHost host = SenselUsbHost::ThisProcess);
  ~SenselUsbDevice();
  SenselUsbDevice(const SenselUsbDevice&) = delete;
  SenselUsbDevice& operator=(const SenselUsbDevice&) = delete;

  const SenselUsbIdentity& identity() const;
  std::string devnode() const;              // /dev/bus/usb/001/NNN of the current plug-in
  std::string root_dir() const;             // the testbed (a host process's UMOCKDEV_DIR)
  bool cdc_acm_bound(int interface) const;  // the kernel's tty driver holds interface 0 or 1

  void stall_for(int ms);  // the next request is lost and nothing answers for `ms`
  void unplug();           // every pending and later request fails with ENODEV; gone from the bus
  void plug_in();          // back on the bus at the next address, cdc_acm bound again

  struct Impl;

 private:
  explicit SenselUsbDevice(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace pvcap::sim
