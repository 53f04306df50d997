#pragma once
// The GigE Vision wire formats pvcap speaks itself, in one place (as Aravis keeps each protocol's
// layout in one header, arvgvcpprivate.h and arvgvspprivate.h): the control protocol's header and
// commands (GVCP: capture/gvcp_ping.cpp reads a register to see a camera answer; ACTION_CMD, the
// scheduled actions of a multi-host rig, docs/multihost.md), the bootstrap
// registers it names, and the stream protocol's packets (GVSP: the simulated cameras' sender,
// sim/gvsp_sender.cpp). Everything on the wire is big-endian. Aravis speaks the rest.
#include <array>
#include <cstdint>
#include <vector>

namespace pvcap::gev {

// --- GVCP (GigE Vision 2.0, chapter 15) ---
inline constexpr std::uint16_t kGvcpPort = 3956;
inline constexpr std::uint8_t kGvcpKey = 0x42;          // the first byte of every command
inline constexpr std::uint8_t kGvcpAckRequired = 0x01;  // the command's flags: answer me
inline constexpr std::size_t kGvcpHeaderBytes = 8;
enum class GvcpCommand : std::uint16_t {
  ReadRegister = 0x0080,
  ReadRegisterAck = 0x0081,
  WriteRegister = 0x0082,
  WriteRegisterAck = 0x0083,
  Action = 0x0100,  // ACTION_CMD: a scheduled or immediate action to every device of a group
  ActionAck = 0x0101,
};

// A command's header: key, flags, command, the payload's length in bytes, the request id (never 0).
inline std::array<std::uint8_t, kGvcpHeaderBytes> gvcp_header(GvcpCommand command, std::uint16_t payload_bytes,
                                                              std::uint16_t request_id) {
  const auto c = std::uint16_t(command);
  return {kGvcpKey,
          kGvcpAckRequired,
          std::uint8_t(c >> 8),
          std::uint8_t(c),
          std::uint8_t(payload_bytes >> 8),
          std::uint8_t(payload_bytes),
          std::uint8_t(request_id >> 8),
          std::uint8_t(request_id)};
}

// An acknowledge's header: status, acknowledge code, length, the id of the request it answers.
struct GvcpAck {
  std::uint16_t status = 0, code = 0, length = 0, id = 0;
};
inline bool parse_gvcp_ack(const std::uint8_t* data, std::size_t size, GvcpAck& ack) {
  if (size < kGvcpHeaderBytes) return false;
  const auto at = [data](int i) { return std::uint16_t((data[i] << 8) | data[i + 1]); };
  ack = {at(0), at(2), at(4), at(6)};
  return true;
}

// ACTION_CMD (GigE Vision 2.0, 16.5): every device whose ActionDeviceKey equals `device_key`, and one
// of whose action signals has `group_key` with a mask sharing a bit with `group_mask`, performs that
// action: at once, or, with an action time (its flag 0x80), when its PTP clock reaches that time
// (ns). Payload: the three keys (32 bits each), then the time (64 bits) when scheduled.
inline constexpr std::uint8_t kGvcpScheduledAction = 0x80;
// An acknowledge's status for a scheduled action whose time had passed when it arrived (an error:
// bit 15, and the code Aravis names ARV_GVCP_ERROR_ACTION_LATE, 0x16).
inline constexpr std::uint16_t kGvcpStatusActionLate = 0x8016;
struct ActionCommand {
  std::uint32_t device_key = 0, group_key = 0, group_mask = 0;
  bool scheduled = false;
  std::uint64_t action_time_ns = 0;  // when scheduled
  bool operator==(const ActionCommand&) const = default;
};
inline std::vector<std::uint8_t> action_command_packet(const ActionCommand& a, std::uint16_t request_id) {
  const auto h = gvcp_header(GvcpCommand::Action, std::uint16_t(a.scheduled ? 20 : 12), request_id);
  std::vector<std::uint8_t> out(h.begin(), h.end());
  if (a.scheduled) out[1] |= kGvcpScheduledAction;
  for (std::uint32_t v : {a.device_key, a.group_key, a.group_mask})
    for (int shift = 24; shift >= 0; shift -= 8) out.push_back(std::uint8_t(v >> shift));
  if (a.scheduled)
    for (int shift = 56; shift >= 0; shift -= 8) out.push_back(std::uint8_t(a.action_time_ns >> shift));
  return out;
}
// A received ACTION_CMD (a device's side: the simulated cameras): false for anything else, or a
// length that does not match its flag.
inline bool parse_action_command(const std::uint8_t* data, std::size_t size, ActionCommand& a,
                                 std::uint16_t& request_id) {
  if (size < kGvcpHeaderBytes || data[0] != kGvcpKey) return false;
  const auto at16 = [data](std::size_t i) { return std::uint16_t((data[i] << 8) | data[i + 1]); };
  if (at16(2) != std::uint16_t(GvcpCommand::Action)) return false;
  const bool scheduled = (data[1] & kGvcpScheduledAction) != 0;
  const std::size_t length = at16(4);
  if (length != (scheduled ? 20u : 12u) || size < kGvcpHeaderBytes + length) return false;
  const auto at32 = [data](std::size_t i) {
    return std::uint32_t(data[i]) << 24 | std::uint32_t(data[i + 1]) << 16 | std::uint32_t(data[i + 2]) << 8 |
           std::uint32_t(data[i + 3]);
  };
  a = {at32(8), at32(12), at32(16), scheduled,
       scheduled ? (std::uint64_t(at32(20)) << 32 | at32(24)) : 0};
  request_id = at16(6);
  return true;
}

// Bootstrap registers (GigE Vision 2.0, table 28).
// GevSCPSPacketSize of stream channel `channel`: the packet size in its low 16 bits.
constexpr std::uint32_t stream_packet_size_register(int channel) { return 0x0D04 + 0x40 * std::uint32_t(channel); }

// --- GVSP (GigE Vision 2.0, chapter 25), standard 16-bit block ids ---
enum class GvspContent : std::uint8_t { Leader = 1, Trailer = 2, Payload = 3 };
inline constexpr std::uint16_t kPayloadImage = 0x0001;
inline constexpr std::uint16_t kPayloadChunkFlag = 0x4000;  // extended chunk mode: the image, then its chunks
inline constexpr std::size_t kGvspHeaderBytes = 8;
inline constexpr unsigned kIpUdpGvspOverhead = 20 + 8 + kGvspHeaderBytes;  // of a packet, before its payload

// Big-endian writers, appending to `out`.
inline void put16(std::vector<std::uint8_t>& out, std::uint16_t v) {
  out.push_back(std::uint8_t(v >> 8));
  out.push_back(std::uint8_t(v));
}
inline void put32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  put16(out, std::uint16_t(v >> 16));
  put16(out, std::uint16_t(v));
}
inline void put64(std::vector<std::uint8_t>& out, std::uint64_t v) {
  put32(out, std::uint32_t(v >> 32));
  put32(out, std::uint32_t(v));
}

// A GVSP packet's header into `out` (cleared): status, block id, content type and the packet's id
// in its block.
inline void gvsp_header(std::vector<std::uint8_t>& out, std::uint16_t block_id, GvspContent content,
                        std::uint32_t packet_id) {
  out.clear();
  put16(out, 0);
  put16(out, block_id);
  put32(out, (std::uint32_t(content) << 24) | (packet_id & 0xffffff));
}

}  // namespace pvcap::gev
