#include "capture/gvcp_ping.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cstdint>

#include "core/time.h"

namespace pvcap {

namespace {

constexpr std::uint16_t kGvcpPort = 3956;
constexpr std::uint8_t kKey = 0x42, kAckRequired = 0x01;
constexpr std::uint16_t kReadRegCmd = 0x0080, kReadRegAck = 0x0081;

struct Socket {
  int fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  ~Socket() {
    if (fd >= 0) ::close(fd);
  }
};

std::uint16_t next_request_id() {
  static std::atomic<std::uint16_t> id{std::uint16_t(host_now().ns)};
  std::uint16_t v = 0;
  while (v == 0) v = id.fetch_add(1);  // 0 is not a valid request id
  return v;
}

}  // namespace

bool is_ipv4(const std::string& address) {
  in_addr a{};
  return inet_pton(AF_INET, address.c_str(), &a) == 1;
}

bool gvcp_answers(const std::string& ipv4, std::chrono::milliseconds timeout) {
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(kGvcpPort);
  if (inet_pton(AF_INET, ipv4.c_str(), &to.sin_addr) != 1) return false;
  Socket s;
  if (s.fd < 0) return false;
  const std::uint16_t id = next_request_id();
  // Header: key, flags, command, payload length, request id; then the address (big-endian).
  const std::array<std::uint8_t, 12> request{kKey,
                                             kAckRequired,
                                             kReadRegCmd >> 8,
                                             kReadRegCmd & 0xFF,
                                             0,
                                             4,
                                             std::uint8_t(id >> 8),
                                             std::uint8_t(id & 0xFF),
                                             0,
                                             0,
                                             0,
                                             0};
  if (sendto(s.fd, request.data(), request.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to) !=
      ssize_t(request.size()))
    return false;
  const std::int64_t deadline = host_now().ns + std::chrono::nanoseconds(timeout).count();
  for (;;) {
    const std::int64_t left_ms = (deadline - host_now().ns) / 1'000'000;
    if (left_ms <= 0) return false;
    pollfd p{s.fd, POLLIN, 0};
    if (poll(&p, 1, int(left_ms)) <= 0) return false;
    std::array<std::uint8_t, 64> ack{};
    const ssize_t n = recv(s.fd, ack.data(), ack.size(), 0);
    // Ack: status, acknowledge, length, ack id (= our request id), then the value.
    if (n >= 8 && ((ack[2] << 8) | ack[3]) == kReadRegAck && ((ack[6] << 8) | ack[7]) == id) return true;
  }
}

}  // namespace pvcap
