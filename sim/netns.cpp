#include "sim/netns.h"

#include <arpa/inet.h>
#include <ifaddrs.h>
#include <net/if.h>
#include <netinet/in.h>
#include <sched.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <set>

#include <fmt/format.h>

namespace pvcap::sim {

namespace {

Status bring_loopback_up() {
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) return Error{fmt::format("socket: {}", std::strerror(errno))};
  ifreq ifr{};
  std::strncpy(ifr.ifr_name, "lo", IFNAMSIZ - 1);
  int rc = ioctl(fd, SIOCGIFFLAGS, &ifr);
  if (rc == 0) {
    ifr.ifr_flags |= IFF_UP | IFF_RUNNING;
    rc = ioctl(fd, SIOCSIFFLAGS, &ifr);
  }
  const int err = errno;
  close(fd);
  if (rc != 0) return Error{fmt::format("cannot bring loopback up: {}", std::strerror(err))};
  return {};
}

// Adds an address as an alias label (lo:N), the classic ioctl way: no netlink, no `ip` binary.
Status add_loopback_address(const std::string& address, int alias) {
  sockaddr_in sin{};
  sin.sin_family = AF_INET;
  if (inet_pton(AF_INET, address.c_str(), &sin.sin_addr) != 1)
    return Error{fmt::format("'{}' is not an IPv4 address", address)};
  if ((ntohl(sin.sin_addr.s_addr) >> 24) != 127)
    return Error{fmt::format("simulated camera address {} is not in 127.0.0.0/8 (loopback only)", address)};
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) return Error{fmt::format("socket: {}", std::strerror(errno))};
  ifreq ifr{};
  std::snprintf(ifr.ifr_name, IFNAMSIZ, "lo:%d", alias);
  std::memcpy(&ifr.ifr_addr, &sin, sizeof sin);
  int rc = ioctl(fd, SIOCSIFADDR, &ifr);
  if (rc == 0) {
    sockaddr_in mask{};
    mask.sin_family = AF_INET;
    mask.sin_addr.s_addr = htonl(0xFF000000);
    std::memcpy(&ifr.ifr_netmask, &mask, sizeof mask);
    rc = ioctl(fd, SIOCSIFNETMASK, &ifr);
  }
  const int err = errno;
  close(fd);
  if (rc != 0) return Error{fmt::format("cannot add {} to loopback: {}", address, std::strerror(err))};
  return {};
}

}  // namespace

bool addresses_present(const std::vector<std::string>& addresses) {
  ifaddrs* list = nullptr;
  if (getifaddrs(&list) != 0) return false;
  std::set<std::string> have;
  for (ifaddrs* a = list; a; a = a->ifa_next) {
    if (!a->ifa_addr || a->ifa_addr->sa_family != AF_INET) continue;
    char text[INET_ADDRSTRLEN] = {};
    inet_ntop(AF_INET, &reinterpret_cast<sockaddr_in*>(a->ifa_addr)->sin_addr, text, sizeof text);
    have.insert(text);
  }
  freeifaddrs(list);
  for (const auto& a : addresses)
    if (!have.count(a)) return false;
  return true;
}

Status enter_private_network(const std::vector<std::string>& addresses) {
  if (unshare(CLONE_NEWNET) != 0)
    return Error{
        fmt::format("cannot create a private network namespace for the simulated rig: {} (run as root, "
                    "or grant CAP_SYS_ADMIN and CAP_NET_ADMIN)",
                    std::strerror(errno))};
  if (Status s = bring_loopback_up(); !s.ok()) return s;
  int alias = 0;
  for (const auto& a : addresses) {
    if (a == "127.0.0.1") continue;
    if (Status s = add_loopback_address(a, alias++); !s.ok()) return s;
  }
  return {};
}

}  // namespace pvcap::sim
