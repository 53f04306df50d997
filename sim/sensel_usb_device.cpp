#include "sim/sensel_usb_device.h"

#include <linux/usbdevice_fs.h>
#include <pthread.h>
#include <sched.h>
#include <sys/ioctl.h>
#include <umockdev.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <deque>
#include <filesystem>
#include <mutex>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include <spdlog/spdlog.h>
#include "core/time.h"

namespace pvcap::sim {
namespace {

constexpr int kBus = 1;
constexpr std::uint16_t kVendor = 0x2C2F, kProduct = 0x0003;
constexpr unsigned char kBulkOut = 0x02, kBulkIn = 0x82;
constexpr int kDataInterface = 1;

void put16(std::vector<std::uint8_t>& v, std::uint16_t x) {
  v.push_back(std::uint8_t(x & 0xFF));
  v.push_back(std::uint8_t(x >> 8));
}

// Device descriptor + the configuration as a Morph reports it (protocol spec §1): CDC-ACM
// control (0) and data (1), then the HID mouse, MIDI, HID digitizer and precision-touchpad
// interfaces with their endpoints. Class-specific descriptors are left out; nothing on the
// host side reads them.
std::vector<std::uint8_t> morph_descriptors() {
  std::vector<std::uint8_t> d = {18, 1};
  put16(d, 0x0200);
  d.insert(d.end(), {0xEF, 0x02, 0x01, 64});  // composite with interface association
  put16(d, kVendor);
  put16(d, kProduct);
  put16(d, 0x0100);
  d.insert(d.end(), {1, 2, 3, 1});  // manufacturer, product, serial strings; one configuration

  struct Ep {
    std::uint8_t address, attributes;
    std::uint16_t max_packet;
    std::uint8_t interval;
  };
  struct If {
    std::uint8_t cls, sub, proto;
    std::vector<Ep> eps;
  };
  const std::vector<If> interfaces = {
      {0x02, 0x02, 0x01, {{0x81, 0x03, 8, 255}}}, {0x0A, 0x00, 0x00, {{kBulkOut, 0x02, 64, 0}, {kBulkIn, 0x02, 64, 0}}},
      {0x03, 0x01, 0x02, {{0x83, 0x03, 19, 1}}},  {0x01, 0x03, 0x00, {{0x04, 0x02, 64, 0}, {0x84, 0x02, 64, 0}}},
      {0x03, 0x00, 0x00, {{0x85, 0x03, 32, 1}}},  {0x03, 0x00, 0x00, {{0x86, 0x03, 64, 1}}},
  };
  std::vector<std::uint8_t> c = {9, 2, 0, 0, std::uint8_t(interfaces.size()), 1, 0, 0x80, 250};  // 500 mA
  const std::uint8_t iad[] = {8, 11, 0, 2, 0x02, 0x02, 0x01, 0};  // CDC function: interfaces 0-1
  c.insert(c.end(), std::begin(iad), std::end(iad));
  for (std::size_t i = 0; i < interfaces.size(); ++i) {
    const If& f = interfaces[i];
    c.insert(c.end(), {9, 4, std::uint8_t(i), 0, std::uint8_t(f.eps.size()), f.cls, f.sub, f.proto, 0});
    for (const Ep& e : f.eps) {
      c.insert(c.end(), {7, 5, e.address, e.attributes});
      put16(c, e.max_packet);
      c.push_back(e.interval);
    }
  }
  c[2] = std::uint8_t(c.size() & 0xFF);
  c[3] = std::uint8_t(c.size() >> 8);
  d.insert(d.end(), c.begin(), c.end());
  return d;
}

std::vector<std::uint8_t> string_descriptor(const std::string& ascii) {
  std::vector<std::uint8_t> s = {std::uint8_t(2 + 2 * ascii.size()), 3};
  for (char ch : ascii) put16(s, std::uint8_t(ch));  // UTF-16LE
  return s;
}

}  // namespace

// Named (not in the anonymous namespace): Impl, declared in the header, holds one.
struct GObjectUnref {
  void operator()(gpointer p) const {
    if (p) g_object_unref(p);
  }
};

// One submitted URB: the client's usbdevfs_urb and its buffer, both resolved into
// local copies that umockdev writes back when the URB is reaped.
struct Urb {
  UMockdevIoctlData* urb = nullptr;      // owned reference
  UMockdevIoctlData* buffer = nullptr;   // owned reference (null for an empty buffer)
  UMockdevIoctlClient* owner = nullptr;  // the open file that submitted it, the only one to reap it
  bool complete = false;                 // OUT and control URBs complete at submission
  usbdevfs_urb* get() const { return reinterpret_cast<usbdevfs_urb*>(urb->data); }
};

struct SenselUsbDevice::Impl {
  Impl(SenselEmulator& emulator, SenselLink link, SenselUsbIdentity id)
      : emu(emulator), pacer(emulator, link), identity(std::move(id)), descriptors(morph_descriptors()) {}

  SenselEmulator& emu;
  SenselPacer pacer;
  SenselUsbIdentity identity;
  const std::vector<std::uint8_t> descriptors;
  std::unique_ptr<UMockdevTestbed, GObjectUnref> testbed;
  // One handler per plug-in: a handler of an earlier plug-in answers ENODEV forever.
  struct Plug {
    Impl* impl;
    int generation;
    UMockdevIoctlBase* handler;
  };
  std::vector<std::unique_ptr<Plug>> plugs;

  std::mutex mu;  // everything below: the handler runs on umockdev's worker thread
  int generation = 0;
  bool plugged = false;
  int devnum = 1;
  std::string syspath;
  bool acm_bound[2] = {true, true};
  UMockdevIoctlClient* claimed_by[2] = {nullptr, nullptr};  // which open file holds each CDC interface
  std::deque<Urb> urbs;                                     // submitted, not yet reaped, in submission order
  std::deque<PacedAnswer> answers;                          // device bytes not yet carried to the host
  std::int64_t stalled_until_ns = 0;
  bool lose_next_request = false;

  std::string devnode() const { return fmt::format("/dev/bus/usb/{:03d}/{:03d}", kBus, devnum); }

  Status add_to_bus() {
    ++devnum;
    const std::string name = fmt::format("{}-1", kBus);
    const std::string busnum = std::to_string(kBus), dev = std::to_string(devnum);
    const std::string node = devnode();
    const std::string product_prop = fmt::format("{:x}/{:x}/100", kVendor, kProduct);
    const std::string majmin = fmt::format("189:{}", (kBus - 1) * 128 + devnum - 1);  // usb_device major
    const gchar* attributes[] = {"busnum",
                                 busnum.c_str(),
                                 "devnum",
                                 dev.c_str(),
                                 "speed",
                                 "12",
                                 "idVendor",
                                 "2c2f",
                                 "idProduct",
                                 "0003",
                                 "bcdDevice",
                                 "0100",
                                 "bConfigurationValue",
                                 "1",
                                 "bNumConfigurations",
                                 "1",
                                 "bNumInterfaces",
                                 " 6",
                                 "manufacturer",
                                 identity.manufacturer.c_str(),
                                 "product",
                                 identity.product.c_str(),
                                 "serial",
                                 identity.serial.c_str(),
                                 "dev",
                                 majmin.c_str(),
                                 nullptr};
    const std::string busnum_prop = fmt::format("{:03d}", kBus), devnum_prop = fmt::format("{:03d}", devnum);
    const gchar* properties[] = {"DEVTYPE", "usb_device",         "DEVNAME", node.c_str(),
                                 "BUSNUM",  busnum_prop.c_str(),  "DEVNUM",  devnum_prop.c_str(),
                                 "PRODUCT", product_prop.c_str(), "DRIVER",  "usb",
                                 nullptr};
    gchar* path = umockdev_testbed_add_devicev(testbed.get(), "usb", name.c_str(), nullptr,
                                               const_cast<gchar**>(attributes), const_cast<gchar**>(properties));
    if (!path) return Error{"umockdev could not add the emulated Sensel Morph"};
    syspath = path;
    g_free(path);
    // The device node: a plain file in the testbed (umockdev's way for USB), its ioctls ours.
    gchar* root = umockdev_testbed_get_root_dir(testbed.get());
    const std::filesystem::path node_file = std::filesystem::path(root) / node.substr(1);
    g_free(root);
    std::error_code ec;
    std::filesystem::create_directories(node_file.parent_path(), ec);
    if (FILE* f = std::fopen(node_file.c_str(), "w"))
      std::fclose(f);
    else
      return Error{
          fmt::format("cannot create the emulated device node {}: {}", node_file.string(), std::strerror(errno))};
    umockdev_testbed_set_attribute_binary(testbed.get(), syspath.c_str(), "descriptors",
                                          const_cast<guint8*>(descriptors.data()), gssize(descriptors.size()));

    auto plug = std::make_unique<Plug>(Plug{this, ++generation, umockdev_ioctl_base_new()});
    g_signal_connect(plug->handler, "handle-ioctl", G_CALLBACK(&Impl::on_ioctl), plug.get());
    g_signal_connect(plug->handler, "client-vanished", G_CALLBACK(&Impl::on_close), plug.get());
    GError* err = nullptr;
    if (!umockdev_testbed_attach_ioctl(testbed.get(), node.c_str(), plug->handler, &err)) {
      std::string msg = fmt::format("umockdev cannot emulate {}: {}", node, err ? err->message : "?");
      g_clear_error(&err);
      return Error{msg};
    }
    plugs.push_back(std::move(plug));
    acm_bound[0] = acm_bound[1] = true;
    claimed_by[0] = claimed_by[1] = nullptr;
    plugged = true;
    return {};
  }

  static gboolean on_ioctl(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer user) {
    // A Morph answers on its own silicon: umockdev's worker thread, which carries every request
    // and answer, takes a real-time priority where allowed (as the pseudo-terminal's server does).
    static thread_local const bool raised = [] {
      sched_param rt{};
      rt.sched_priority = 10;
      return pthread_setschedparam(pthread_self(), SCHED_FIFO, &rt) == 0;
    }();
    (void)raised;
    auto* plug = static_cast<Plug*>(user);
    Impl& self = *plug->impl;
    std::lock_guard lock(self.mu);
    if (!self.plugged || plug->generation != self.generation) {
      // Gone. As on Linux, what was in flight is still reaped (status -ESHUTDOWN, which libusb
      // reports as "no device"), then everything fails with ENODEV.
      const gulong request = umockdev_ioctl_client_get_request(client);
      if (request == USBDEVFS_REAPURB || request == USBDEVFS_REAPURBNDELAY) {
        GError* err = nullptr;
        std::unique_ptr<UMockdevIoctlData, GObjectUnref> slot(
            umockdev_ioctl_data_resolve(umockdev_ioctl_client_get_arg(client), 0, sizeof(void*), &err));
        g_clear_error(&err);
        if (slot && self.reap_one(client, slot.get())) {
          umockdev_ioctl_client_complete(client, 0, 0);
          return TRUE;
        }
      }
      umockdev_ioctl_client_complete(client, -1, ENODEV);
      return TRUE;
    }
    self.handle(client);
    return TRUE;
  }

  // The host closed its file: the kernel releases what that file had claimed.
  static void on_close(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer user) {
    Impl& self = *static_cast<Plug*>(user)->impl;
    std::lock_guard lock(self.mu);
    for (auto& owner : self.claimed_by)
      if (owner == client) owner = nullptr;
    for (auto it = self.urbs.begin(); it != self.urbs.end();)
      if (it->owner == client) {
        release(*it);
        it = self.urbs.erase(it);
      } else {
        ++it;
      }
  }

  void handle(UMockdevIoctlClient* client) {
    const gulong request = umockdev_ioctl_client_get_request(client);
    UMockdevIoctlData* arg = umockdev_ioctl_client_get_arg(client);
    const gsize size = (request >> _IOC_SIZESHIFT) & ((1u << _IOC_SIZEBITS) - 1);
    std::unique_ptr<UMockdevIoctlData, GObjectUnref> data;
    if (size > 0) {
      GError* err = nullptr;
      data.reset(umockdev_ioctl_data_resolve(arg, 0, size, &err));
      if (!data) {
        g_clear_error(&err);
        umockdev_ioctl_client_complete(client, -1, EFAULT);
        return;
      }
    }
    auto done = [&](long result, int error) { umockdev_ioctl_client_complete(client, result, error); };

    switch (request) {
      case USBDEVFS_GET_CAPABILITIES:
        *reinterpret_cast<std::uint32_t*>(data->data) = USBDEVFS_CAP_ZERO_PACKET | USBDEVFS_CAP_BULK_CONTINUATION |
                                                        USBDEVFS_CAP_NO_PACKET_SIZE_LIM |
                                                        USBDEVFS_CAP_REAP_AFTER_DISCONNECT;
        return done(0, 0);
      case USBDEVFS_GETDRIVER: {
        auto* gd = reinterpret_cast<usbdevfs_getdriver*>(data->data);
        if (gd->interface < 2 && acm_bound[gd->interface]) {
          std::snprintf(gd->driver, sizeof gd->driver, "cdc_acm");
          return done(0, 0);
        }
        if (gd->interface < 2 && claimed_by[gd->interface]) {
          std::snprintf(gd->driver, sizeof gd->driver, "usbfs");
          return done(0, 0);
        }
        return done(-1, ENODATA);
      }
      case USBDEVFS_IOCTL: {
        const auto* io = reinterpret_cast<const usbdevfs_ioctl*>(data->data);
        if (io->ifno < 0 || io->ifno >= 6) return done(-1, EINVAL);
        if (io->ifno >= 2) return done(-1, ENODATA);  // the HID/MIDI drivers are not emulated
        if (io->ioctl_code == int(USBDEVFS_DISCONNECT)) {
          if (!acm_bound[io->ifno]) return done(-1, ENODATA);
          acm_bound[io->ifno] = false;
          return done(0, 0);
        }
        if (io->ioctl_code == int(USBDEVFS_CONNECT)) {
          if (claimed_by[io->ifno]) return done(-1, EBUSY);
          acm_bound[io->ifno] = true;
          return done(1, 0);  // a driver was bound
        }
        return done(-1, ENOTTY);
      }
      case USBDEVFS_CLAIMINTERFACE:
      case USBDEVFS_RELEASEINTERFACE: {
        const unsigned ifno = *reinterpret_cast<const unsigned*>(data->data);
        if (ifno >= 6) return done(-1, ENOENT);
        if (ifno < 2) {
          UMockdevIoctlClient*& owner = claimed_by[ifno];
          if (request == USBDEVFS_RELEASEINTERFACE) {
            if (owner != client) return done(-1, EINVAL);
            owner = nullptr;
            return done(0, 0);
          }
          // What Linux says while cdc_acm or another program holds the interface.
          if (acm_bound[ifno] || (owner && owner != client)) return done(-1, EBUSY);
          owner = client;
        }
        return done(0, 0);
      }
      case USBDEVFS_SETINTERFACE:
      case USBDEVFS_CLEAR_HALT:
      case USBDEVFS_RESETEP:
        return done(0, 0);
      case USBDEVFS_SUBMITURB:
        return submit(client, std::move(data), done);
      case USBDEVFS_DISCARDURB: {
        const gulong address = *reinterpret_cast<const gulong*>(arg->data);
        for (Urb& u : urbs)
          if (u.owner == client && u.urb->client_addr == address && !u.complete) {
            u.get()->status = -ENOENT;  // reaped as cancelled
            u.get()->actual_length = 0;
            u.complete = true;
            return done(0, 0);
          }
        return done(-1, EINVAL);  // already completed: the host reaps it normally
      }
      case USBDEVFS_REAPURB:
      case USBDEVFS_REAPURBNDELAY:
        return reap(client, data.get(), done);
      default:
        spdlog::debug("emulated Sensel USB: unhandled usbdevfs request {:#x}", request);
        return done(-1, ENOTTY);
    }
  }

  template <class Done>
  void submit(UMockdevIoctlClient* client, std::unique_ptr<UMockdevIoctlData, GObjectUnref> data, Done& done) {
    auto* u = reinterpret_cast<usbdevfs_urb*>(data->data);
    Urb entry;
    if (u->buffer_length > 0) {
      GError* err = nullptr;
      entry.buffer =
          umockdev_ioctl_data_resolve(data.get(), offsetof(usbdevfs_urb, buffer), gsize(u->buffer_length), &err);
      if (!entry.buffer) {
        g_clear_error(&err);
        return done(-1, EFAULT);
      }
    }
    u->status = 0;
    u->actual_length = 0;
    if (u->type == USBDEVFS_URB_TYPE_CONTROL) {
      control(*u, entry.buffer ? entry.buffer->data : nullptr);
      entry.complete = true;
    } else if (u->type == USBDEVFS_URB_TYPE_BULK && u->endpoint == kBulkOut) {
      if (!may_use_data_interface(client)) return release(entry), done(-1, EBUSY);
      host_bytes(
          std::span<const std::uint8_t>(entry.buffer ? entry.buffer->data : nullptr, std::size_t(u->buffer_length)));
      u->actual_length = u->buffer_length;
      entry.complete = true;
    } else if (u->type == USBDEVFS_URB_TYPE_BULK && u->endpoint == kBulkIn) {
      if (!may_use_data_interface(client)) return release(entry), done(-1, EBUSY);
    } else {
      return release(entry), done(-1, ENOENT);  // no such endpoint on this interface set
    }
    entry.urb = data.release();
    entry.owner = client;
    urbs.push_back(entry);
    done(0, 0);
  }

  // Linux claims an unclaimed interface implicitly on the first URB, and refuses one held by
  // cdc_acm or another open file.
  bool may_use_data_interface(UMockdevIoctlClient* client) {
    UMockdevIoctlClient*& owner = claimed_by[kDataInterface];
    if (acm_bound[kDataInterface] || (owner && owner != client)) return false;
    owner = client;
    return true;
  }

  void host_bytes(std::span<const std::uint8_t> bytes) {
    const std::int64_t now = host_now().ns;
    if (lose_next_request) {  // a hung device: the request is lost and nothing answers for a while
      lose_next_request = false;
      return;
    }
    PacedAnswer a = pacer.answer(bytes, now);
    a.deliver_at_ns = std::max(a.deliver_at_ns, stalled_until_ns);
    if (!a.bytes.empty()) answers.push_back(std::move(a));
  }

  // Standard GET_DESCRIPTOR requests; CDC class requests (line coding, control lines) are accepted.
  void control(usbdevfs_urb& u, std::uint8_t* buffer) {
    if (!buffer || u.buffer_length < 8) {
      u.status = -EPIPE;
      return;
    }
    const std::uint8_t request_type = buffer[0], request = buffer[1];
    const std::uint16_t value = std::uint16_t(buffer[2] | buffer[3] << 8);
    const std::uint16_t length = std::uint16_t(buffer[6] | buffer[7] << 8);
    std::vector<std::uint8_t> reply;
    if (request_type == 0x80 && request == 6) {
      const int type = value >> 8, index = value & 0xFF;
      if (type == 1)
        reply.assign(descriptors.begin(), descriptors.begin() + 18);
      else if (type == 2)
        reply.assign(descriptors.begin() + 18, descriptors.end());
      else if (type == 3 && index == 0)
        reply = {4, 3, 0x09, 0x04};  // English (US)
      else if (type == 3 && index == 1)
        reply = string_descriptor(identity.manufacturer);
      else if (type == 3 && index == 2)
        reply = string_descriptor(identity.product);
      else if (type == 3 && index == 3)
        reply = string_descriptor(identity.serial);
      else {
        u.status = -EPIPE;  // the device stalls unknown requests
        return;
      }
    } else if ((request_type & 0x80) != 0) {
      u.status = -EPIPE;
      return;
    }
    const std::size_t n = std::min<std::size_t>({reply.size(), length, std::size_t(u.buffer_length - 8)});
    std::memcpy(buffer + 8, reply.data(), n);
    u.actual_length = int(n);
  }

  template <class Done>
  void reap(UMockdevIoctlClient* client, UMockdevIoctlData* slot, Done& done) {
    complete_due(client);
    if (reap_one(client, slot)) return done(0, 0);
    // Nothing to reap. usbdevfs nodes in the testbed are plain files, so the host's poll() never
    // blocks: the wait is here instead, while an IN transfer of this client waits for its answer,
    // until the answer is due (at most 2 ms, what an unplug or another client may wait), then the
    // reap is tried once more. (A 0.5 ms nap and EAGAIN cost the host ~16 round trips per frame.)
    const bool waiting = std::any_of(urbs.begin(), urbs.end(), [&](const Urb& u) {
      return u.owner == client && !u.complete && u.get()->endpoint == kBulkIn;
    });
    if (!waiting) return done(-1, EAGAIN);
    std::int64_t wait_ns = 2'000'000;
    if (!answers.empty()) wait_ns = std::clamp<std::int64_t>(answers.front().deliver_at_ns - host_now().ns, 0, wait_ns);
    if (wait_ns > 0) std::this_thread::sleep_for(std::chrono::nanoseconds(wait_ns));
    complete_due(client);
    if (reap_one(client, slot)) return done(0, 0);
    done(-1, EAGAIN);
  }

  // Completes `client`'s IN URBs with the answers that are due, in order.
  void complete_due(UMockdevIoctlClient* client) {
    const std::int64_t now = host_now().ns;
    if (auto pushed = emu.async_frames_due(now); !pushed.empty())  // async scanning pushes unasked
      answers.push_back({std::move(pushed), now});
    for (Urb& u : urbs) {
      usbdevfs_urb* raw = u.get();
      if (u.complete || u.owner != client || raw->endpoint != kBulkIn) continue;
      if (answers.empty() || answers.front().deliver_at_ns > now) break;  // IN URBs complete in order
      // One answer per transfer: the device ends it with a short packet.
      PacedAnswer& a = answers.front();
      const std::size_t n = std::min<std::size_t>(a.bytes.size(), std::size_t(raw->buffer_length));
      std::memcpy(u.buffer->data, a.bytes.data(), n);
      a.bytes.erase(a.bytes.begin(), a.bytes.begin() + std::ptrdiff_t(n));
      if (a.bytes.empty()) answers.pop_front();
      raw->actual_length = int(n);
      u.complete = true;
    }
  }

  // Hands `client` its oldest completed URB (and its buffer) through the REAPURB slot.
  bool reap_one(UMockdevIoctlClient* client, UMockdevIoctlData* slot) {
    for (auto it = urbs.begin(); it != urbs.end(); ++it) {
      if (it->owner != client || !it->complete) continue;
      Urb entry = *it;
      urbs.erase(it);
      umockdev_ioctl_data_set_ptr(slot, 0, entry.urb);
      release(entry);
      return true;
    }
    return false;
  }

  // The device vanished: whatever was in flight completes as "shut down".
  void shut_down_urbs() {
    for (Urb& u : urbs)
      if (!u.complete) {
        u.get()->status = -ESHUTDOWN;
        u.get()->actual_length = 0;
        u.complete = true;
      }
    answers.clear();
  }

  static void release(Urb& u) {
    if (u.buffer) g_object_unref(u.buffer);
    if (u.urb) g_object_unref(u.urb);
    u.buffer = u.urb = nullptr;
  }

  void drop_urbs() {
    for (Urb& u : urbs) release(u);
    urbs.clear();
    answers.clear();
  }
};

SenselUsbDevice::SenselUsbDevice(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Result<std::unique_ptr<SenselUsbDevice>> SenselUsbDevice::create(SenselEmulator& emulator, SenselLink link,
                                                                 SenselUsbIdentity identity, SenselUsbHost host) {
  auto impl = std::make_unique<Impl>(emulator, link, std::move(identity));
  impl->testbed.reset(umockdev_testbed_new());
  // Only meaningful once a testbed exists: the preload library then redirects /sys.
  if (host == SenselUsbHost::ThisProcess && !umockdev_in_mock_environment())
    return Error{
        "the emulated USB Sensel needs umockdev's preload library: run under umockdev-wrapper "
        "(LD_PRELOAD=libumockdev-preload.so.0)"};
  std::lock_guard lock(impl->mu);
  if (auto s = impl->add_to_bus(); !s.ok()) return s.error();
  return std::unique_ptr<SenselUsbDevice>(new SenselUsbDevice(std::move(impl)));
}

SenselUsbDevice::~SenselUsbDevice() {
  {
    std::lock_guard lock(impl_->mu);
    impl_->plugged = false;
    impl_->drop_urbs();
  }
  impl_->testbed.reset();  // stops the worker thread before the handlers go
  for (auto& p : impl_->plugs) g_object_unref(p->handler);
}

const SenselUsbIdentity& SenselUsbDevice::identity() const { return impl_->identity; }

std::string SenselUsbDevice::root_dir() const {
  gchar* root = umockdev_testbed_get_root_dir(impl_->testbed.get());
  std::string out = root ? root : "";
  g_free(root);
  return out;
}

std::string SenselUsbDevice::devnode() const {
  std::lock_guard lock(impl_->mu);
  return impl_->devnode();
}

bool SenselUsbDevice::cdc_acm_bound(int interface) const {
  std::lock_guard lock(impl_->mu);
  return interface >= 0 && interface < 2 && impl_->acm_bound[interface];
}

void SenselUsbDevice::stall_for(int ms) {
  std::lock_guard lock(impl_->mu);
  impl_->lose_next_request = true;
  impl_->stalled_until_ns = host_now().ns + std::int64_t(ms) * 1'000'000;
}

void SenselUsbDevice::unplug() {
  std::lock_guard lock(impl_->mu);
  if (!impl_->plugged) return;
  impl_->plugged = false;
  impl_->shut_down_urbs();
  umockdev_testbed_remove_device(impl_->testbed.get(), impl_->syspath.c_str());
}

void SenselUsbDevice::plug_in() {
  std::lock_guard lock(impl_->mu);
  if (impl_->plugged) return;
  if (auto s = impl_->add_to_bus(); !s.ok()) spdlog::error("{}", s.error().message);
}

}  // namespace pvcap::sim
