#pragma once
// The Sensel Morph register protocol (protocol spec §3-4): 3-byte commands, a
// 1-byte ack, little-endian lengths, an 8-bit sum checksum over the payload.
// parse_response() reads one response incrementally from a byte stream and
// checks everything the official library does not: the ack code, the echoed
// register, the header byte, the length and the checksum.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace pvcap::sensel {

namespace reg {
inline constexpr std::uint8_t kMagic = 0x00;                // 6 bytes "S3NS31"
inline constexpr std::uint8_t kFirmwareInfo = 0x06;         // 10 bytes
inline constexpr std::uint8_t kSerialNumber = 0x0F;         // variable size (16)
inline constexpr std::uint8_t kSensorCols = 0x10;           // u16
inline constexpr std::uint8_t kSensorRows = 0x12;           // u16
inline constexpr std::uint8_t kWidthUm = 0x14;              // u32
inline constexpr std::uint8_t kHeightUm = 0x18;             // u32
inline constexpr std::uint8_t kCompressionMetadata = 0x1C;  // variable size (6)
inline constexpr std::uint8_t kScanFrameRate = 0x20;        // u16
inline constexpr std::uint8_t kScanBufferControl = 0x22;
inline constexpr std::uint8_t kScanDetail = 0x23;    // 0 high, 1 medium, 2 low
inline constexpr std::uint8_t kFrameContent = 0x24;  // Content bits
inline constexpr std::uint8_t kScanEnabled = 0x25;   // 0 off, 1 sync, 2 async
inline constexpr std::uint8_t kReadFrame = 0x26;     // variable size: one frame
inline constexpr std::uint8_t kContentSupported = 0x28;
inline constexpr std::uint8_t kContactsMaxCount = 0x40;
inline constexpr std::uint8_t kContactsMask = 0x4B;
inline constexpr std::uint8_t kBaselineEnabled = 0x50;
inline constexpr std::uint8_t kDynamicBaseline = 0x57;
inline constexpr std::uint8_t kUnitShiftForce = 0xA1;
inline constexpr std::uint8_t kSoftReset = 0xE0;
}  // namespace reg

enum Ack : std::uint8_t {
  kReadAck = 1,
  kReadNack = 2,
  kRvsAck = 3,
  kRvsNack = 4,
  kWriteAck = 5,
  kWriteNack = 6,
  kWvsAck = 7,
  kWvsNack = 8,
  kAsyncData = 9,
  kBufferedEnd = 10,
};
inline constexpr char kMagicText[] = "S3NS31";

std::vector<std::uint8_t> command_read(std::uint8_t reg, std::uint8_t size);  // 81 reg size
std::vector<std::uint8_t> command_read_variable(std::uint8_t reg);            // 81 reg 00
std::vector<std::uint8_t> command_write(std::uint8_t reg, std::span<const std::uint8_t> data);

// Variable-size write (WVS, spec §3): a header announcing the total length, then chunks of at
// most kWvsMaxChunk bytes. The device acks the header with `07 reg` and each chunk with `07`.
inline constexpr std::size_t kWvsMaxChunk = 512;
std::vector<std::uint8_t> command_write_variable_header(std::uint8_t reg,
                                                        std::uint32_t total);                 // 01 reg 00 04 n0..n3 chk
std::vector<std::uint8_t> command_write_variable_chunk(std::span<const std::uint8_t> chunk);  // len_lo len_hi data chk

enum class Expect { Read, ReadVariable, Write, WriteVariableHeader, WriteVariableChunk };

struct Response {
  enum class State { NeedMore, Ok, Bad } state = State::NeedMore;
  std::size_t consumed = 0;  // bytes used (Ok), or to skip before resynchronising (Bad)
  std::uint8_t ack = 0;
  std::uint8_t reg = 0;
  std::vector<std::uint8_t> data;  // register bytes or frame payload
  std::string error;               // why, when Bad
};

// Parses the response to a command of kind `expect` on `reg` (`size` bytes for a fixed read)
// from the start of `bytes`. An async frame (ack 9) that arrives first is returned as such
// (ack == kAsyncData) and the caller keeps reading for its own response. In buffered scanning a
// frame read answers with several frames (ack 3 each) and then a single 0x0A (ack == kBufferedEnd).
Response parse_response(std::span<const std::uint8_t> bytes, Expect expect, std::uint8_t reg, std::uint8_t size = 0);

// What a device answers, for the emulator: the inverse of parse_response.
std::vector<std::uint8_t> response_read(std::uint8_t reg, std::span<const std::uint8_t> data);
std::vector<std::uint8_t> response_read_variable(std::uint8_t ack, std::uint8_t reg,
                                                 std::span<const std::uint8_t> payload);
std::vector<std::uint8_t> response_write(std::uint8_t reg);
std::vector<std::uint8_t> response_write_variable_header(std::uint8_t reg);  // 07 reg
std::vector<std::uint8_t> response_write_variable_chunk();                   // 07

}  // namespace pvcap::sensel
