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

#include "capture/gige_vision_wire.h"

namespace pvcap::sim {

using gev::put32;
using gev::put64;

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
  value(f.line_status, kLineStatusChunkId);
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
  gev::gvsp_header(packet_, f.block_id, gev::GvspContent::Leader, packet_id++);
  gev::put16(packet_, 0);  // flags
  gev::put16(packet_, gev::kPayloadImage | gev::kPayloadChunkFlag);
  put64(packet_, f.timestamp);
  put32(packet_, f.pixel_format);
  put32(packet_, f.width);
  put32(packet_, f.height);
  put32(packet_, f.x);
  put32(packet_, f.y);
  gev::put16(packet_, 0);  // padding x, y
  gev::put16(packet_, 0);
  send_packet(to, packet_, loss);

  const std::vector<std::uint8_t> chunks = chunk_data(f);
  const std::size_t total = f.image.size() + chunks.size();
  const std::size_t per_packet =
      packet_size > gev::kIpUdpGvspOverhead + 8 ? packet_size - gev::kIpUdpGvspOverhead : 1400;
  for (std::size_t at = 0; at < total; at += per_packet) {
    gev::gvsp_header(packet_, f.block_id, gev::GvspContent::Payload, packet_id++);
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

  gev::gvsp_header(packet_, f.block_id, gev::GvspContent::Trailer, packet_id);
  put32(packet_, gev::kPayloadImage | gev::kPayloadChunkFlag);  // reserved, then the payload type
  put32(packet_, f.height);
  send_packet(to, packet_, loss);
}

}  // namespace pvcap::sim
