// ACTION_CMD sent by pvcap (capture/gvcp_ping.h), to devices on loopback that read it with the shared
// layout (capture/gige_vision_wire.h) and acknowledge it: each device gets its command, each
// acknowledge is matched to its device by request id, and a device that never answers is named.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <thread>

#include "capture/gvcp_ping.h"

namespace {

using namespace pvcap;

// A device at 127.0.0.1:<port>: receives one datagram, keeps what it read, answers when told to.
struct FakeDevice {
  int fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  std::uint16_t port = 0;
  gev::ActionCommand received;
  bool parsed = false;
  explicit FakeDevice(std::uint16_t ack_status) : status(ack_status) {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
    socklen_t len = sizeof a;
    getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
    port = ntohs(a.sin_port);
  }
  ~FakeDevice() {
    if (thread.joinable()) thread.join();
    close(fd);
  }
  void serve(bool answer) {
    thread = std::thread([this, answer] {
      pollfd p{fd, POLLIN, 0};
      if (poll(&p, 1, 2000) <= 0) return;
      std::array<std::uint8_t, 64> in{};
      sockaddr_in from{};
      socklen_t len = sizeof from;
      const ssize_t n = recvfrom(fd, in.data(), in.size(), 0, reinterpret_cast<sockaddr*>(&from), &len);
      std::uint16_t id = 0;
      parsed = n > 0 && gev::parse_action_command(in.data(), std::size_t(n), received, id);
      if (!answer || !parsed) return;
      const std::uint8_t ack[] = {std::uint8_t(status >> 8), std::uint8_t(status), 0x01, 0x01, 0, 0,
                                  std::uint8_t(id >> 8), std::uint8_t(id)};
      sendto(fd, ack, sizeof ack, 0, reinterpret_cast<sockaddr*>(&from), len);
    });
  }
  std::uint16_t status;
  std::thread thread;
};

TEST(GvcpAction, AScheduledActionReachesTheDeviceAndItsAcknowledgeIsRead) {
  FakeDevice device(0);
  device.serve(true);
  const gev::ActionCommand action{0x5EED, 1, 0x1, true, 1'796'690'033'000'000'000ull};
  const auto answers = send_action_command({"127.0.0.1"}, action, std::chrono::milliseconds(1000), device.port);
  ASSERT_TRUE(answers) << answers.error().message;
  ASSERT_EQ(answers.value().size(), 1u);
  EXPECT_TRUE(answers.value()[0].acknowledged);
  EXPECT_EQ(answers.value()[0].status, 0);
  device.thread.join();
  EXPECT_TRUE(device.parsed);
  EXPECT_EQ(device.received, action);
}

TEST(GvcpAction, ADeviceThatDoesNotAnswerIsNamedAndALateStatusIsKept) {
  FakeDevice silent(0);
  silent.serve(false);
  const auto none = send_action_command({"127.0.0.1"}, {1, 1, 1, false, 0}, std::chrono::milliseconds(200), silent.port);
  ASSERT_TRUE(none) << none.error().message;
  EXPECT_FALSE(none.value()[0].acknowledged);
  EXPECT_EQ(none.value()[0].address, "127.0.0.1");
  FakeDevice late(gev::kGvcpStatusActionLate);  // its action's time had passed when it came
  late.serve(true);
  const auto answered = send_action_command({"127.0.0.1"}, {1, 1, 1, true, 5}, std::chrono::milliseconds(1000), late.port);
  ASSERT_TRUE(answered) << answered.error().message;
  EXPECT_TRUE(answered.value()[0].acknowledged);
  EXPECT_EQ(answered.value()[0].status, gev::kGvcpStatusActionLate);
  const auto bad = send_action_command({"not-an-address"}, {1, 1, 1, false, 0}, std::chrono::milliseconds(10));
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("not 'not-an-address'"), std::string::npos) << bad.error().message;
}

}  // namespace
