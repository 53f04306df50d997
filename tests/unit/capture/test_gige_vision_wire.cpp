// The GigE Vision layouts pvcap writes itself (capture/gige_vision_wire.h), byte for byte as the
// standard and Aravis' arvgvcpprivate.h / arvgvspprivate.h lay them out.
#include <gtest/gtest.h>

#include <vector>

#include "capture/gige_vision_wire.h"

using namespace pvcap;

TEST(GigeVisionWire, AReadRegisterCommandIsTheStandardsHeader) {
  const auto h = gev::gvcp_header(gev::GvcpCommand::ReadRegister, 4, 0x1234);
  EXPECT_EQ(std::vector<std::uint8_t>(h.begin(), h.end()),
            (std::vector<std::uint8_t>{0x42, 0x01, 0x00, 0x80, 0x00, 0x04, 0x12, 0x34}));
  const auto action = gev::gvcp_header(gev::GvcpCommand::Action, 20, 7);
  EXPECT_EQ(action[2], 0x01);
  EXPECT_EQ(action[3], 0x00);
  EXPECT_EQ(action[5], 20);
}

TEST(GigeVisionWire, AnAcknowledgeIsReadAndAShortOneRefused) {
  const std::uint8_t ack[] = {0x00, 0x00, 0x00, 0x81, 0x00, 0x04, 0x12, 0x34, 0, 0, 0, 1};
  gev::GvcpAck a;
  ASSERT_TRUE(gev::parse_gvcp_ack(ack, sizeof ack, a));
  EXPECT_EQ(a.status, 0);
  EXPECT_EQ(a.code, std::uint16_t(gev::GvcpCommand::ReadRegisterAck));
  EXPECT_EQ(a.length, 4);
  EXPECT_EQ(a.id, 0x1234);
  EXPECT_FALSE(gev::parse_gvcp_ack(ack, 7, a));
}

TEST(GigeVisionWire, StreamPacketsAndRegisters) {
  std::vector<std::uint8_t> p{9, 9};
  gev::gvsp_header(p, 0xBEEF, gev::GvspContent::Payload, 0x123456);
  EXPECT_EQ(p, (std::vector<std::uint8_t>{0x00, 0x00, 0xBE, 0xEF, 0x03, 0x12, 0x34, 0x56}));
  gev::put64(p, 0x0102030405060708ull);
  EXPECT_EQ(p.size(), 16u);
  EXPECT_EQ(p[8], 0x01);
  EXPECT_EQ(p[15], 0x08);
  EXPECT_EQ(gev::stream_packet_size_register(0), 0x0D04u);
  EXPECT_EQ(gev::stream_packet_size_register(1), 0x0D44u);
  EXPECT_EQ(gev::kPayloadImage | gev::kPayloadChunkFlag, 0x4001);
}

// ACTION_CMD as GigE Vision 2.0 lays it out (and Wireshark's GVCP dissector reads it): the scheduled
// flag 0x80 beside the acknowledge flag, the device, group key and mask, then the 64-bit time.
TEST(GigeVisionWire, AnActionCommandImmediateOrScheduledReadsBackAsSent) {
  const gev::ActionCommand now{0x11223344, 0x00112233, 0xFFFFFFFF, false, 0};
  const auto p = gev::action_command_packet(now, 0x0102);
  EXPECT_EQ(p, (std::vector<std::uint8_t>{0x42, 0x01, 0x01, 0x00, 0x00, 0x0C, 0x01, 0x02, 0x11, 0x22, 0x33, 0x44,
                                          0x00, 0x11, 0x22, 0x33, 0xFF, 0xFF, 0xFF, 0xFF}));
  const gev::ActionCommand at{7, 1, 0x3, true, 1'796'690'033'855'857'181ull};
  const auto q = gev::action_command_packet(at, 9);
  ASSERT_EQ(q.size(), 28u);
  EXPECT_EQ(q[1], 0x81) << "scheduled, acknowledge required";
  EXPECT_EQ(q[5], 20);
  EXPECT_EQ(q[20], 0x18);  // 1796690033855857181 = 0x18EF...: its most significant byte first
  gev::ActionCommand back;
  std::uint16_t id = 0;
  ASSERT_TRUE(gev::parse_action_command(q.data(), q.size(), back, id));
  EXPECT_EQ(back, at);
  EXPECT_EQ(id, 9);
  ASSERT_TRUE(gev::parse_action_command(p.data(), p.size(), back, id));
  EXPECT_EQ(back, now);
  // A length that does not match the flag, a cut packet, another command: refused.
  auto wrong = q;
  wrong[1] = 0x01;
  EXPECT_FALSE(gev::parse_action_command(wrong.data(), wrong.size(), back, id));
  EXPECT_FALSE(gev::parse_action_command(q.data(), q.size() - 1, back, id));
  const auto read = gev::gvcp_header(gev::GvcpCommand::ReadRegister, 4, 1);
  EXPECT_FALSE(gev::parse_action_command(read.data(), read.size(), back, id));
}
