#include "sim/gvsp_sender.h"

#include <arpa/inet.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cstring>
#include <utility>

#include <fmt/format.h>

namespace pvcap::sim {

namespace {
constexpr std::uint16_t kPayloadImageWithChunks = 0x4001;
constexpr std::uint8_t kLeader = 1, kTrailer = 2, kPayload = 3;
constexpr unsigned kOverhead = 20 + 8 + 8;  // IP, UDP and GVSP headers

void put16(std::vector<std::uint8_t>& out, std::uint16_t v) {
  out.push_back(std::uint8_t(v >> 8));
  out.push_back(std::uint8_t(v));
}
void put32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  put16(out, std::uint16_t(v >> 16));
  put16(out, std::uint16_t(v));
}
void put64(std::vector<std::uint8_t>& out, std::uint64_t v) {
  put32(out, std::uint32_t(v >> 32));
  put32(out, std::uint32_t(v));
}

// GVSP's header: status, block id, then the content type and the packet's id in the block.
void header(std::vector<std::uint8_t>& out, std::uint16_t block_id, std::uint8_t content, std::uint32_t packet_id) {
  out.clear();
  put16(out, 0);
  put16(out, block_id);
  put32(out, (std::uint32_t(content) << 24) | (packet_id & 0xffffff));
}
}  // namespace

std::vector<std::uint8_t> chunk_data(const GvspFrame& f) {
  std::vector<std::uint8_t> out;
  out.reserve(kChunkBytes);
  put32(out, kImageChunkId);  // the image's own tag: the chunks before it are the image
  put32(out, std::uint32_t(f.image.size()));
  const auto value = [&out](std::uint64_t bits, std::uint32_t id) {
    put64(out, bits);
    put32(out, id);
    put32(out, 8);
  };
  value(f.frame_counter, kFrameIdChunkId);
  value(f.timestamp, kTimestampChunkId);
  value(std::bit_cast<std::uint64_t>(f.exposure_us), kExposureTimeChunkId);
  value(std::bit_cast<std::uint64_t>(f.gain), kGainChunkId);
  return out;
}

Result<GvspSender> GvspSender::open(const std::string& address) {
  sockaddr_in at{};
  at.sin_family = AF_INET;
  if (::inet_pton(AF_INET, address.c_str(), &at.sin_addr) != 1)
    return Error{fmt::format("{}: not an IPv4 address for the stream's sender", address)};
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return Error{fmt::format("cannot make the stream's socket: {}", std::strerror(errno))};
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&at), sizeof at) != 0) {
    const int e = errno;
    ::close(fd);
    return Error{fmt::format("cannot bind the stream's socket to {}: {}", address, std::strerror(e))};
  }
  return GvspSender(fd);
}

GvspSender::GvspSender(GvspSender&& o) noexcept
    : fd_(std::exchange(o.fd_, -1)), rng_(o.rng_), packet_(std::move(o.packet_)) {}

GvspSender::~GvspSender() {
  if (fd_ >= 0) ::close(fd_);
}

void GvspSender::send_packet(const sockaddr_in& to, const std::vector<std::uint8_t>& packet, double loss) {
  if (loss > 0 && std::uniform_real_distribution<double>(0, 1)(rng_) < loss) return;
  (void)::sendto(fd_, packet.data(), packet.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to);
}

void GvspSender::send(const sockaddr_in& to, unsigned packet_size, const GvspFrame& f, double loss) {
  std::uint32_t packet_id = 0;
  header(packet_, f.block_id, kLeader, packet_id++);
  put16(packet_, 0);  // flags
  put16(packet_, kPayloadImageWithChunks);
  put64(packet_, f.timestamp);
  put32(packet_, f.pixel_format);
  put32(packet_, f.width);
  put32(packet_, f.height);
  put32(packet_, f.x);
  put32(packet_, f.y);
  put16(packet_, 0);  // padding x, y
  put16(packet_, 0);
  send_packet(to, packet_, loss);

  const std::vector<std::uint8_t> chunks = chunk_data(f);
  const std::size_t total = f.image.size() + chunks.size();
  const std::size_t per_packet = packet_size > kOverhead + 8 ? packet_size - kOverhead : 1400;
  for (std::size_t at = 0; at < total; at += per_packet) {
    header(packet_, f.block_id, kPayload, packet_id++);
    const std::size_t end = std::min(total, at + per_packet);
    // The payload is the image, then its chunks: a packet may hold the end of one and the start of the other.
    if (at < f.image.size())
      packet_.insert(packet_.end(), f.image.begin() + std::ptrdiff_t(at),
                     f.image.begin() + std::ptrdiff_t(std::min(end, f.image.size())));
    if (end > f.image.size()) {
      const std::size_t from = std::max(at, f.image.size()) - f.image.size();
      packet_.insert(packet_.end(), chunks.begin() + std::ptrdiff_t(from),
                     chunks.begin() + std::ptrdiff_t(end - f.image.size()));
    }
    send_packet(to, packet_, loss);
  }

  header(packet_, f.block_id, kTrailer, packet_id);
  put32(packet_, kPayloadImageWithChunks);
  put32(packet_, f.height);
  send_packet(to, packet_, loss);
}

}  // namespace pvcap::sim
