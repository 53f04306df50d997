#include "codec/sensel_protocol.h"

#include <fmt/format.h>

#include "codec/sensel_frame.h"

namespace pvcap::sensel {

std::vector<std::uint8_t> command_read(std::uint8_t reg, std::uint8_t size) { return {0x81, reg, size}; }
std::vector<std::uint8_t> command_read_variable(std::uint8_t reg) { return {0x81, reg, 0x00}; }
std::vector<std::uint8_t> command_write(std::uint8_t reg, std::span<const std::uint8_t> data) {
  std::vector<std::uint8_t> out = {0x01, reg, std::uint8_t(data.size())};
  out.insert(out.end(), data.begin(), data.end());
  out.push_back(checksum(data));
  return out;
}

std::vector<std::uint8_t> command_write_variable_header(std::uint8_t reg, std::uint32_t total) {
  const std::uint8_t n[4] = {std::uint8_t(total), std::uint8_t(total >> 8), std::uint8_t(total >> 16),
                             std::uint8_t(total >> 24)};
  return {0x01, reg, 0x00, 0x04, n[0], n[1], n[2], n[3], checksum(n)};
}
std::vector<std::uint8_t> command_write_variable_chunk(std::span<const std::uint8_t> chunk) {
  std::vector<std::uint8_t> out = {std::uint8_t(chunk.size()), std::uint8_t(chunk.size() >> 8)};
  out.insert(out.end(), chunk.begin(), chunk.end());
  out.push_back(checksum(chunk));
  return out;
}

std::vector<std::uint8_t> response_read(std::uint8_t reg, std::span<const std::uint8_t> data) {
  std::vector<std::uint8_t> out = {kReadAck, reg, std::uint8_t(data.size()), std::uint8_t(data.size() >> 8)};
  out.insert(out.end(), data.begin(), data.end());
  out.push_back(checksum(data));
  return out;
}
std::vector<std::uint8_t> response_read_variable(std::uint8_t ack, std::uint8_t reg,
                                                 std::span<const std::uint8_t> payload) {
  std::vector<std::uint8_t> out = {ack, reg, 0x00, std::uint8_t(payload.size()), std::uint8_t(payload.size() >> 8)};
  out.insert(out.end(), payload.begin(), payload.end());
  out.push_back(checksum(payload));
  return out;
}
std::vector<std::uint8_t> response_write(std::uint8_t reg) { return {kWriteAck, reg}; }
std::vector<std::uint8_t> response_write_variable_header(std::uint8_t reg) { return {kWvsAck, reg}; }
std::vector<std::uint8_t> response_write_variable_chunk() { return {kWvsAck}; }

namespace {
Response ok(std::size_t consumed, std::uint8_t ack, std::uint8_t reg) {
  Response r;
  r.state = Response::State::Ok;
  r.consumed = consumed;
  r.ack = ack;
  r.reg = reg;
  return r;
}

Response bad(std::size_t skip, std::string why) {
  Response r;
  r.state = Response::State::Bad;
  r.consumed = skip;
  r.error = std::move(why);
  return r;
}

// `ack reg [hdr] len_lo len_hi payload chk` with `header` bytes between reg and length.
Response parse_sized(std::span<const std::uint8_t> b, std::uint8_t reg, int header) {
  const std::size_t head = 2 + std::size_t(header) + 2;
  if (b.size() < head) return {};
  if (b[1] != reg) return bad(1, fmt::format("answer for register 0x{:02x}, expected 0x{:02x}", b[1], reg));
  if (header && b[2] != 0) return bad(1, fmt::format("header byte 0x{:02x}, expected 0", b[2]));
  const std::size_t len = std::size_t(b[head - 2]) | (std::size_t(b[head - 1]) << 8);
  if (b.size() < head + len + 1) return {};
  const auto payload = b.subspan(head, len);
  const std::uint8_t chk = b[head + len];
  if (checksum(payload) != chk)
    return bad(head + len + 1,
               fmt::format("checksum 0x{:02x}, the {} bytes sum to 0x{:02x}", chk, len, checksum(payload)));
  Response r = ok(head + len + 1, b[0], b[1]);
  r.data.assign(payload.begin(), payload.end());
  return r;
}
}  // namespace

Response parse_response(std::span<const std::uint8_t> b, Expect expect, std::uint8_t reg, std::uint8_t size) {
  if (b.empty()) return {};
  const std::uint8_t ack = b[0];
  if (ack == kAsyncData) return parse_sized(b, reg::kReadFrame, 1);
  switch (expect) {
    case Expect::Read: {
      if (ack == kReadNack) return bad(1, fmt::format("the device refused to read register 0x{:02x} (NACK)", reg));
      if (ack != kReadAck) return bad(1, fmt::format("ack 0x{:02x} where a read ack (1) was expected", ack));
      Response r = parse_sized(b, reg, 0);
      if (r.state == Response::State::Ok && r.data.size() != size)
        return bad(r.consumed, fmt::format("register 0x{:02x}: {} bytes, expected {}", reg, r.data.size(), size));
      return r;
    }
    case Expect::ReadVariable:
      if (ack == kBufferedEnd && reg == reg::kReadFrame) return ok(1, ack, reg);  // end of a buffered burst
      if (ack == kRvsNack) return bad(1, fmt::format("the device refused to read register 0x{:02x} (NACK)", reg));
      if (ack != kRvsAck) return bad(1, fmt::format("ack 0x{:02x} where a variable-read ack (3) was expected", ack));
      return parse_sized(b, reg, 1);
    case Expect::Write: {
      if (ack == kWriteNack) return bad(1, fmt::format("the device refused to write register 0x{:02x} (NACK)", reg));
      if (ack != kWriteAck) return bad(1, fmt::format("ack 0x{:02x} where a write ack (5) was expected", ack));
      if (b.size() < 2) return {};
      if (b[1] != reg) return bad(1, fmt::format("write ack for register 0x{:02x}, expected 0x{:02x}", b[1], reg));
      return ok(2, ack, reg);
    }
    case Expect::WriteVariableHeader:
    case Expect::WriteVariableChunk: {
      if (ack == kWvsNack)
        return bad(1, fmt::format("the device refused the variable write to register 0x{:02x} (NACK)", reg));
      if (ack != kWvsAck) return bad(1, fmt::format("ack 0x{:02x} where a variable-write ack (7) was expected", ack));
      if (expect == Expect::WriteVariableChunk) return ok(1, ack, reg);
      if (b.size() < 2) return {};
      if (b[1] != reg)
        return bad(1, fmt::format("variable-write ack for register 0x{:02x}, expected 0x{:02x}", b[1], reg));
      return ok(2, ack, reg);
    }
  }
  return bad(1, "unknown expectation");
}

}  // namespace pvcap::sensel
