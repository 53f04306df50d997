#pragma once
// A GigE Vision stream sender (GVSP, standard 16-bit block ids) for a simulated camera whose frames
// carry chunk data: Aravis' fake-camera engine (0.8.26) sends only image leaders, so a camera with
// chunk mode on sends its frames through this one instead (the engine's own packets are then
// dropped: its "gvsp-lost-ratio" at 1). A frame goes out as a camera in extended chunk mode sends
// it: a leader of payload type 0x4001 (image with chunks), the image followed by its chunks, each
// tagged after its data with its id and length (big-endian), and a trailer.
#include <netinet/in.h>

#include <cstdint>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "core/result.h"

namespace pvcap::sim {

// The chunk ids the simulated camera's node map declares for its chunk values (sim/fake_camera_features.cpp).
inline constexpr std::uint32_t kImageChunkId = 0x00000001;
inline constexpr std::uint32_t kFrameIdChunkId = 0x00010001;
inline constexpr std::uint32_t kTimestampChunkId = 0x00010002;
inline constexpr std::uint32_t kExposureTimeChunkId = 0x00010003;
inline constexpr std::uint32_t kGainChunkId = 0x00010004;
inline constexpr std::uint32_t kLineStatusChunkId = 0x00010005;
// What the chunks add to a frame's payload: the image's tag, and five 8-byte values with their tags.
inline constexpr std::size_t kChunkBytes = 8 + 5 * (8 + 8);

struct GvspFrame {
  std::uint16_t block_id = 0;  // the frame id (never 0 on GigE Vision)
  std::uint64_t timestamp = 0;
  std::uint32_t pixel_format = 0;
  std::uint32_t width = 0, height = 0, x = 0, y = 0;
  std::span<const std::uint8_t> image;
  std::uint64_t frame_counter = 0;  // the chunks' values
  double exposure_us = 0, gain = 0;
  std::uint64_t line_status = 0;  // bit N: LineN high
};

// The chunk data of `frame` as it follows its image in the payload.
std::vector<std::uint8_t> chunk_data(const GvspFrame& frame);

class GvspSender {
 public:
  // A UDP socket on the camera's `address` (the source a receiver's filter expects).
  static Result<GvspSender> open(const std::string& address);
  GvspSender(GvspSender&& o) noexcept;
  GvspSender& operator=(GvspSender&&) = delete;
  GvspSender(const GvspSender&) = delete;
  ~GvspSender();

  // Sends `frame` with its chunks to `destination` in packets of at most `packet_size` bytes (IP and
  // UDP headers included, as GevSCPSPacketSize counts them); each packet is dropped with probability
  // `loss` (the simulated link's). A packet the network refuses is lost, as a camera's would be (a
  // camera sends on; the receiver counts what is missing).
  void send(const sockaddr_in& destination, unsigned packet_size, const GvspFrame& frame, double loss);

 private:
  explicit GvspSender(int fd) : fd_(fd) {}
  void send_packet(const sockaddr_in& to, const std::vector<std::uint8_t>& packet, double loss);
  int fd_ = -1;
  std::mt19937_64 rng_{0x5eed};
  std::vector<std::uint8_t> packet_;
};

}  // namespace pvcap::sim
