// The Sensel Morph's protocol channel straight over USB (libusb), without the
// kernel's cdc_acm tty: find VID 0x2C2F / PID 0x0003 by its USB serial string,
// detach cdc_acm from the CDC interfaces, claim the data interface and use its
// bulk endpoints (protocol spec §1). The USB packets (64 bytes) are reassembled by
// libusb into transfers; read() hands them out in whatever pieces the caller asks.
#include <libusb.h>

#include <algorithm>
#include <cstring>
#include <vector>

#include <fmt/format.h>

#include "capture/sensel_transport.h"

namespace pvcap::sensel {
namespace {

constexpr std::uint16_t kVendor = 0x2C2F, kProduct = 0x0003;
constexpr int kControlInterface = 0, kDataInterface = 1;
constexpr unsigned char kBulkOut = 0x02, kBulkIn = 0x82;
constexpr int kWriteTimeoutMs = 1000;

struct ContextDeleter {
  void operator()(libusb_context* c) const { libusb_exit(c); }
};
struct HandleDeleter {
  void operator()(libusb_device_handle* h) const { libusb_close(h); }
};
struct ListDeleter {
  void operator()(libusb_device** l) const { libusb_free_device_list(l, 1); }
};
using Context = std::unique_ptr<libusb_context, ContextDeleter>;
using Handle = std::unique_ptr<libusb_device_handle, HandleDeleter>;

std::string where(libusb_device* d) {
  return fmt::format("/dev/bus/usb/{:03d}/{:03d}", libusb_get_bus_number(d), libusb_get_device_address(d));
}

Result<Context> make_context() {
  libusb_context* c = nullptr;
  if (const int rc = libusb_init(&c); rc != 0)
    return Error{fmt::format("cannot start libusb: {}", libusb_strerror(rc))};
  return Context(c);
}

// Every Morph on the bus with its USB serial; those that cannot be opened carry why.
struct Candidate {
  libusb_device* device;
  std::string serial;
  std::string problem;
  const std::string& shown() const { return problem.empty() ? serial : problem; }  // for listings and messages
};

using DeviceList = std::unique_ptr<libusb_device*, ListDeleter>;
Result<DeviceList> device_list(libusb_context* ctx) {
  libusb_device** raw = nullptr;
  if (const ssize_t n = libusb_get_device_list(ctx, &raw); n < 0)
    return Error{fmt::format("cannot list USB devices: {}", libusb_strerror(int(n)))};
  return DeviceList(raw);
}

std::vector<Candidate> morphs(libusb_device** list) {
  std::vector<Candidate> out;
  for (libusb_device** d = list; *d; ++d) {
    libusb_device_descriptor desc{};
    if (libusb_get_device_descriptor(*d, &desc) != 0 || desc.idVendor != kVendor || desc.idProduct != kProduct)
      continue;
    Candidate c{*d, {}, {}};
    libusb_device_handle* h = nullptr;
    if (const int rc = libusb_open(*d, &h); rc != 0) {
      c.problem =
          rc == LIBUSB_ERROR_ACCESS
              ? fmt::format("{}: permission denied (add the udev rule in docs/sensel.md, or run as root)", where(*d))
              : fmt::format("{}: cannot open: {}", where(*d), libusb_strerror(rc));
    } else {
      unsigned char buf[128];
      const int n = desc.iSerialNumber ? libusb_get_string_descriptor_ascii(h, desc.iSerialNumber, buf, sizeof buf) : 0;
      if (n > 0) c.serial.assign(reinterpret_cast<const char*>(buf), std::size_t(n));
      libusb_close(h);
    }
    out.push_back(std::move(c));
  }
  return out;
}

class UsbTransport : public Transport {
 public:
  UsbTransport(Context ctx, Handle handle, std::string serial, std::string node, std::vector<int> detached)
      : ctx_(std::move(ctx)),
        handle_(std::move(handle)),
        serial_(std::move(serial)),
        node_(std::move(node)),
        detached_(std::move(detached)),
        in_(16384) {}

  ~UsbTransport() override {
    libusb_release_interface(handle_.get(), kDataInterface);
    // Give the tty back to the kernel, as we found it (harmless if the device is gone).
    for (int i : detached_) libusb_attach_kernel_driver(handle_.get(), i);
  }

  Status write(std::span<const std::uint8_t> bytes) override {
    int sent = 0;
    const int rc = libusb_bulk_transfer(handle_.get(), kBulkOut, const_cast<unsigned char*>(bytes.data()),
                                        int(bytes.size()), &sent, kWriteTimeoutMs);
    if (rc == LIBUSB_ERROR_NO_DEVICE) return Error{fmt::format("{}: the device is gone (unplugged?)", describe())};
    if (rc != 0) return Error{fmt::format("{}: write failed: {}", describe(), libusb_strerror(rc))};
    if (std::size_t(sent) != bytes.size())
      return Error{fmt::format("{}: wrote {} of {} bytes", describe(), sent, bytes.size())};
    return {};
  }

  Result<std::size_t> read(std::span<std::uint8_t> into, int timeout_ms) override {
    if (next_ == filled_) {
      next_ = filled_ = 0;
      int got = 0;
      // libusb reads a timeout of 0 as "forever"; ours means "only what is there".
      const int rc = libusb_bulk_transfer(handle_.get(), kBulkIn, in_.data(), int(in_.size()), &got,
                                          unsigned(std::max(timeout_ms, 1)));
      if (rc == LIBUSB_ERROR_NO_DEVICE) return Error{fmt::format("{}: the device is gone (unplugged?)", describe())};
      if (rc != 0 && rc != LIBUSB_ERROR_TIMEOUT)  // a timeout may still have brought bytes
        return Error{fmt::format("{}: read failed: {}", describe(), libusb_strerror(rc))};
      filled_ = std::size_t(got);
    }
    const std::size_t n = std::min(into.size(), filled_ - next_);
    std::memcpy(into.data(), in_.data() + next_, n);
    next_ += n;
    return n;
  }

  std::string describe() const override { return fmt::format("USB Sensel {} ({})", serial_, node_); }

 private:
  Context ctx_;  // declared first: destroyed last
  Handle handle_;
  std::string serial_, node_;
  std::vector<int> detached_;
  std::vector<std::uint8_t> in_;
  std::size_t next_ = 0, filled_ = 0;
};

}  // namespace

Result<std::vector<std::string>> list_usb_sensels() {
  auto ctx = make_context();
  if (!ctx) return ctx.error();
  auto list = device_list(ctx.value().get());
  if (!list) return list.error();
  std::vector<std::string> serials;
  for (const auto& c : morphs(list.value().get())) serials.push_back(c.shown());
  return serials;
}

Result<std::unique_ptr<Transport>> open_usb(const std::string& usb_serial) {
  auto ctx = make_context();
  if (!ctx) return ctx.error();
  auto listed = device_list(ctx.value().get());
  if (!listed) return listed.error();
  DeviceList list = std::move(listed.value());

  const auto found = morphs(list.get());
  const auto wanted = [&](const Candidate& c) { return usb_serial.empty() || c.serial == usb_serial; };
  const auto n_wanted = std::count_if(found.begin(), found.end(), wanted);
  std::string seen;
  for (const auto& c : found) seen += fmt::format("{}{}", seen.empty() ? "" : ", ", c.shown());
  if (n_wanted == 0) {
    if (found.empty())
      return Error{"no Sensel Morph (USB 2c2f:0003) on the USB bus: check the cable (lsusb lists it when it is there)"};
    return Error{fmt::format("no Sensel Morph with USB serial '{}'; found: {}", usb_serial, seen)};
  }
  if (n_wanted > 1)
    return Error{
        fmt::format("{} Sensel Morphs on the USB bus ({}): name one with sensel.usb in the rig file", n_wanted, seen)};
  const Candidate& pick = *std::find_if(found.begin(), found.end(), wanted);
  if (!pick.problem.empty()) return Error{fmt::format("Sensel Morph {}", pick.problem)};

  libusb_device_handle* h = nullptr;
  if (const int rc = libusb_open(pick.device, &h); rc != 0)
    return Error{fmt::format("Sensel Morph {}: cannot open: {}", where(pick.device), libusb_strerror(rc))};
  Handle handle(h);
  const std::string node = where(pick.device);
  std::vector<int> detached;
  for (int i : {kControlInterface, kDataInterface}) {
    if (libusb_kernel_driver_active(h, i) != 1) continue;
    if (const int rc = libusb_detach_kernel_driver(h, i); rc != 0)
      return Error{fmt::format("Sensel Morph {}: cannot detach the kernel's cdc_acm from interface {}: {}", node, i,
                               libusb_strerror(rc))};
    detached.push_back(i);
  }
  if (const int rc = libusb_claim_interface(h, kDataInterface); rc != 0) {
    for (int i : detached) libusb_attach_kernel_driver(h, i);
    return Error{
        fmt::format("Sensel Morph {}: cannot claim its data interface: {}{}", node, libusb_strerror(rc),
                    rc == LIBUSB_ERROR_BUSY ? " (another program has it open: another pvcap, the Sensel app?)" : "")};
  }
  list.reset();  // the handle keeps its device referenced
  return std::unique_ptr<Transport>(
      new UsbTransport(std::move(ctx.value()), std::move(handle), pick.serial, node, std::move(detached)));
}

}  // namespace pvcap::sensel
