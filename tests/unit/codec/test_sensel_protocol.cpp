#include <gtest/gtest.h>

#include "codec/sensel_protocol.h"

using namespace pvcap::sensel;
using State = Response::State;

TEST(SenselProtocol, CommandsHaveTheDocumentedBytes) {
  EXPECT_EQ(command_read(0x10, 2), (std::vector<std::uint8_t>{0x81, 0x10, 0x02}));
  EXPECT_EQ(command_read_variable(reg::kReadFrame), (std::vector<std::uint8_t>{0x81, 0x26, 0x00}));
  const std::uint8_t one[] = {1};
  EXPECT_EQ(command_write(reg::kSoftReset, one), (std::vector<std::uint8_t>{0x01, 0xE0, 0x01, 0x01, 0x01}));
}

TEST(SenselProtocol, FixedReadOfTheColumnCount) {
  // The spec's example: 81 10 02 -> 01 10 02 00 B9 00 B9 (185 columns).
  const std::vector<std::uint8_t> wire = {0x01, 0x10, 0x02, 0x00, 0xB9, 0x00, 0xB9};
  const Response r = parse_response(wire, Expect::Read, 0x10, 2);
  ASSERT_EQ(r.state, State::Ok) << r.error;
  EXPECT_EQ(r.consumed, wire.size());
  EXPECT_EQ(r.data, (std::vector<std::uint8_t>{0xB9, 0x00}));
  EXPECT_EQ(response_read(0x10, r.data), wire);
}

TEST(SenselProtocol, CompressionMetadataAsCapturedFromARealMorph) {
  // The captures' compression_metadata: header 031c000600, data 00005D350202, checksum 150.
  const std::vector<std::uint8_t> wire = {0x03, 0x1C, 0x00, 0x06, 0x00, 0x00, 0x00, 0x5D, 0x35, 0x02, 0x02, 150};
  const Response r = parse_response(wire, Expect::ReadVariable, reg::kCompressionMetadata);
  ASSERT_EQ(r.state, State::Ok) << r.error;
  EXPECT_EQ(r.data.size(), 6u);
  EXPECT_EQ(response_read_variable(kRvsAck, reg::kCompressionMetadata, r.data), wire);
}

TEST(SenselProtocol, PartialInputAsksForMoreAtEveryCut) {
  const std::vector<std::uint8_t> wire = {0x03, 0x1C, 0x00, 0x06, 0x00, 0x00, 0x00, 0x5D, 0x35, 0x02, 0x02, 150};
  for (std::size_t n = 0; n < wire.size(); ++n)
    EXPECT_EQ(parse_response(std::span(wire).first(n), Expect::ReadVariable, reg::kCompressionMetadata).state,
              State::NeedMore)
        << n;
}

TEST(SenselProtocol, BadChecksumIsRejectedAndTheWholeResponseSkipped) {
  std::vector<std::uint8_t> wire = {0x03, 0x1C, 0x00, 0x06, 0x00, 0x00, 0x00, 0x5D, 0x35, 0x02, 0x02, 151};
  const Response r = parse_response(wire, Expect::ReadVariable, reg::kCompressionMetadata);
  EXPECT_EQ(r.state, State::Bad);
  EXPECT_EQ(r.consumed, wire.size());
  EXPECT_NE(r.error.find("checksum"), std::string::npos);
}

TEST(SenselProtocol, WrongRegisterAckAndHeaderAreEachNamed) {
  const std::vector<std::uint8_t> other_reg = {0x01, 0x12, 0x02, 0x00, 0x69, 0x00, 0x69};
  EXPECT_NE(parse_response(other_reg, Expect::Read, 0x10, 2).error.find("register 0x12"), std::string::npos);
  const std::vector<std::uint8_t> nack = {kReadNack, 0x10};
  EXPECT_NE(parse_response(nack, Expect::Read, 0x10, 2).error.find("NACK"), std::string::npos);
  const std::vector<std::uint8_t> header = {0x03, 0x26, 0x07, 0x00, 0x00, 0x00};
  EXPECT_NE(parse_response(header, Expect::ReadVariable, 0x26).error.find("header byte"), std::string::npos);
  const std::vector<std::uint8_t> size = {0x01, 0x10, 0x01, 0x00, 0xB9, 0xB9};
  EXPECT_NE(parse_response(size, Expect::Read, 0x10, 2).error.find("1 bytes, expected 2"), std::string::npos);
}

TEST(SenselProtocol, AsyncFrameBeforeAWriteAckIsReturnedFirst) {
  const std::vector<std::uint8_t> frame = {0x09, 0x26, 0x00, 0x02, 0x00, 0x11, 0x22, 0x33, 0x05, 0x25};
  const Response r = parse_response(frame, Expect::Write, reg::kScanEnabled);
  ASSERT_EQ(r.state, State::Ok) << r.error;
  EXPECT_EQ(r.ack, kAsyncData);
  EXPECT_EQ(r.consumed, 8u);
  const Response w = parse_response(std::span(frame).subspan(r.consumed), Expect::Write, reg::kScanEnabled);
  ASSERT_EQ(w.state, State::Ok);
  EXPECT_EQ(w.ack, kWriteAck);
}

TEST(SenselProtocol, VariableWriteHasTheDocumentedHeaderChunksAndAcks) {
  // 600 bytes to LED_BRIGHTNESS: `01 80 00 04` + u32 LE total + checksum over the four length bytes.
  EXPECT_EQ(command_write_variable_header(0x80, 600),
            (std::vector<std::uint8_t>{0x01, 0x80, 0x00, 0x04, 0x58, 0x02, 0x00, 0x00, 0x5A}));
  const std::uint8_t data[] = {0x10, 0x20, 0xF0};
  EXPECT_EQ(command_write_variable_chunk(data), (std::vector<std::uint8_t>{0x03, 0x00, 0x10, 0x20, 0xF0, 0x20}));

  const std::vector<std::uint8_t> header_ack = {0x07, 0x80}, chunk_ack = {0x07};
  auto r = parse_response(header_ack, Expect::WriteVariableHeader, 0x80);
  EXPECT_EQ(r.state, Response::State::Ok);
  EXPECT_EQ(r.consumed, 2u);
  EXPECT_EQ(parse_response(std::vector<std::uint8_t>{0x07}, Expect::WriteVariableHeader, 0x80).state,
            Response::State::NeedMore);
  EXPECT_EQ(parse_response(chunk_ack, Expect::WriteVariableChunk, 0x80).consumed, 1u);
  const auto wrong = parse_response(std::vector<std::uint8_t>{0x07, 0x81}, Expect::WriteVariableHeader, 0x80);
  EXPECT_EQ(wrong.state, Response::State::Bad);
  EXPECT_NE(wrong.error.find("0x81"), std::string::npos) << wrong.error;
  const auto nack = parse_response(std::vector<std::uint8_t>{0x08}, Expect::WriteVariableChunk, 0x80);
  EXPECT_EQ(nack.state, Response::State::Bad);
  EXPECT_NE(nack.error.find("NACK"), std::string::npos) << nack.error;
}
