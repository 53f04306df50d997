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
