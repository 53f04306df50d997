#include "capture/gvcp_ping.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cstring>
#include <atomic>
#include <cerrno>
#include <cstdint>
#include <vector>

#include <fmt/format.h>

#include "capture/gige_vision_wire.h"
#include "core/time.h"

namespace pvcap {

namespace {

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

bool send_to(const Socket& s, const std::string& ipv4, std::uint16_t port, const std::vector<std::uint8_t>& packet) {
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(port);
  if (inet_pton(AF_INET, ipv4.c_str(), &to.sin_addr) != 1) return false;
  return sendto(s.fd, packet.data(), packet.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to) ==
         ssize_t(packet.size());
}

// Acknowledges arriving on `s` until `done` says so of one, or `wait` has passed.
template <typename Done>
void await_acks(const Socket& s, std::chrono::milliseconds wait, Done done) {
  const std::int64_t deadline = host_now().ns + std::chrono::nanoseconds(wait).count();
  for (;;) {
    const std::int64_t left_ms = (deadline - host_now().ns) / 1'000'000;
    if (left_ms <= 0) return;
    pollfd p{s.fd, POLLIN, 0};
    if (poll(&p, 1, int(left_ms)) <= 0) return;
    std::array<std::uint8_t, 64> ack{};
    const ssize_t n = recv(s.fd, ack.data(), ack.size(), 0);
    gev::GvcpAck a;
    if (n > 0 && gev::parse_gvcp_ack(ack.data(), std::size_t(n), a) && done(a)) return;
  }
}

}  // namespace

bool is_ipv4(const std::string& address) {
  in_addr a{};
  return inet_pton(AF_INET, address.c_str(), &a) == 1;
}

bool gvcp_answers(const std::string& ipv4, std::chrono::milliseconds timeout) {
  Socket s;
  if (s.fd < 0) return false;
  const std::uint16_t id = next_request_id();
  // A read of the first bootstrap register: any device that answers GVCP answers it.
  std::vector<std::uint8_t> request;
  for (const std::uint8_t b : gev::gvcp_header(gev::GvcpCommand::ReadRegister, 4, id)) request.push_back(b);
  gev::put32(request, 0);
  if (!send_to(s, ipv4, gev::kGvcpPort, request)) return false;
  bool answered = false;
  await_acks(s, timeout, [&](const gev::GvcpAck& a) {
    answered = a.code == std::uint16_t(gev::GvcpCommand::ReadRegisterAck) && a.id == id;
    return answered;
  });
  return answered;
}

Result<std::vector<ActionAnswer>> send_action_command(const std::vector<std::string>& addresses,
                                                      const gev::ActionCommand& action,
                                                      std::chrono::milliseconds wait, std::uint16_t port) {
  Socket s;
  if (s.fd < 0) return Error{fmt::format("cannot open a socket for an action command: {}", std::strerror(errno))};
  std::vector<ActionAnswer> answers;
  std::vector<std::uint16_t> ids;
  for (const std::string& address : addresses) {
    if (!is_ipv4(address)) return Error{fmt::format("an action command goes to an IPv4 address, not '{}'", address)};
    const std::uint16_t id = next_request_id();
    if (!send_to(s, address, port, gev::action_command_packet(action, id)))
      return Error{fmt::format("cannot send an action command to {}: {}", address, std::strerror(errno))};
    answers.push_back({address});
    ids.push_back(id);
  }
  std::size_t left = answers.size();
  if (left > 0)
    await_acks(s, wait, [&](const gev::GvcpAck& a) {
      if (a.code != std::uint16_t(gev::GvcpCommand::ActionAck)) return false;
      for (std::size_t i = 0; i < ids.size(); ++i)
        if (ids[i] == a.id && !answers[i].acknowledged) {
          answers[i].acknowledged = true;
          answers[i].status = a.status;
          --left;
        }
      return left == 0;
    });
  return answers;
}

}  // namespace pvcap
