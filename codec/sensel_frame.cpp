#include "codec/sensel_frame.h"

#include <fmt/format.h>

namespace pvcap::sensel {

namespace {

// Little-endian reader that refuses to run past the end.
struct Reader {
  std::span<const std::uint8_t> in;
  std::size_t pos = 0;
  bool need(std::size_t n) const { return pos + n <= in.size(); }
  std::uint8_t u8() { return in[pos++]; }
  std::uint16_t u16() {
    const std::uint16_t v = std::uint16_t(in[pos] | (in[pos + 1] << 8));
    pos += 2;
    return v;
  }
  std::int16_t s16() { return std::int16_t(u16()); }
  std::uint32_t u32() {
    const std::uint32_t v = std::uint32_t(in[pos]) | (std::uint32_t(in[pos + 1]) << 8) |
                            (std::uint32_t(in[pos + 2]) << 16) | (std::uint32_t(in[pos + 3]) << 24);
    pos += 4;
    return v;
  }
};

void put16(std::vector<std::uint8_t>& out, std::uint16_t v) {
  out.push_back(std::uint8_t(v));
  out.push_back(std::uint8_t(v >> 8));
}

constexpr std::size_t kBaseContactBytes = 10;
std::size_t contact_bytes(std::uint8_t groups) {
  return kBaseContactBytes + ((groups & kEllipse) ? 6 : 0) + ((groups & kDeltas) ? 8 : 0) +
         ((groups & kBoundingBox) ? 8 : 0) + ((groups & kPeak) ? 6 : 0);
}
constexpr int kMaxContacts = 16;

}  // namespace

std::uint8_t checksum(std::span<const std::uint8_t> payload) {
  unsigned sum = 0;
  for (std::uint8_t b : payload) sum += b;
  return std::uint8_t(sum);
}

Result<Frame> parse_frame(std::span<const std::uint8_t> payload, const Grid& grid) {
  Reader r{payload};
  Frame f;
  if (!r.need(6)) return Error{fmt::format("frame of {} bytes is shorter than its 6-byte header", payload.size())};
  f.content = r.u8();
  f.counter = r.u8();
  f.timestamp_us = r.u32();
  if (f.content & 0xF0) return Error{fmt::format("unknown content bits 0x{:02x}", f.content)};
  if (f.content & kContacts) {
    if (!r.need(2)) return Error{"contacts: section header truncated"};
    f.contact_groups = r.u8();
    const int count = r.u8();
    if (f.contact_groups & 0xF0) return Error{fmt::format("contacts: unknown group bits 0x{:02x}", f.contact_groups)};
    if (count > kMaxContacts) return Error{fmt::format("contacts: {} contacts, the device reports at most 16", count)};
    if (!r.need(std::size_t(count) * contact_bytes(f.contact_groups)))
      return Error{fmt::format("contacts: {} contacts do not fit in the {} bytes left", count, payload.size() - r.pos)};
    for (int i = 0; i < count; ++i) {
      Contact c;
      c.id = r.u8();
      c.state = r.u8();
      c.x = r.u16();
      c.y = r.u16();
      c.total_force = r.u16();
      c.area = r.u16();
      if (f.contact_groups & kEllipse) c.orientation = r.s16(), c.major = r.u16(), c.minor = r.u16();
      if (f.contact_groups & kDeltas) c.dx = r.s16(), c.dy = r.s16(), c.dforce = r.s16(), c.darea = r.s16();
      if (f.contact_groups & kBoundingBox) c.min_x = r.u16(), c.min_y = r.u16(), c.max_x = r.u16(), c.max_y = r.u16();
      if (f.contact_groups & kPeak) c.peak_x = r.u16(), c.peak_y = r.u16(), c.peak_force = r.u16();
      f.contacts.push_back(c);
    }
  }
  if (f.content & kAccel) {
    if (!r.need(6)) return Error{"accelerometer: section truncated"};
    Accel a;
    a.x = r.s16();
    a.y = r.s16();
    a.z = r.s16();
    f.accel = a;
  }
  if (f.content & kPressure) {
    auto p = decode_pressure(payload, r.pos, grid);
    if (!p) return p.error();
    f.pressure = std::move(p.value());
  }
  if (f.content & kLabels) {
    auto l = decode_labels(payload, r.pos, grid);
    if (!l) return l.error();
    f.labels = std::move(l.value());
  }
  if (r.pos != payload.size())
    return Error{fmt::format("{} bytes left over after the last section (wrong grid, or a corrupt frame)",
                             payload.size() - r.pos)};
  return f;
}

std::vector<std::uint8_t> encode_frame(const Frame& f) {
  std::vector<std::uint8_t> out;
  out.push_back(f.content);
  out.push_back(f.counter);
  for (int i = 0; i < 4; ++i) out.push_back(std::uint8_t(f.timestamp_us >> (8 * i)));
  if (f.content & kContacts) {
    out.push_back(f.contact_groups);
    out.push_back(std::uint8_t(f.contacts.size()));
    for (const Contact& c : f.contacts) {
      out.push_back(c.id);
      out.push_back(c.state);
      for (std::uint16_t v : {c.x, c.y, c.total_force, c.area}) put16(out, v);
      if (f.contact_groups & kEllipse)
        for (std::uint16_t v : {std::uint16_t(c.orientation), c.major, c.minor}) put16(out, v);
      if (f.contact_groups & kDeltas)
        for (std::int16_t v : {c.dx, c.dy, c.dforce, c.darea}) put16(out, std::uint16_t(v));
      if (f.contact_groups & kBoundingBox)
        for (std::uint16_t v : {c.min_x, c.min_y, c.max_x, c.max_y}) put16(out, v);
      if (f.contact_groups & kPeak)
        for (std::uint16_t v : {c.peak_x, c.peak_y, c.peak_force}) put16(out, v);
    }
  }
  if ((f.content & kAccel) && f.accel)
    for (std::int16_t v : {f.accel->x, f.accel->y, f.accel->z}) put16(out, std::uint16_t(v));
  if ((f.content & kPressure) && f.pressure) {
    const auto p = encode_pressure(*f.pressure);
    out.insert(out.end(), p.begin(), p.end());
  }
  if ((f.content & kLabels) && f.labels) {
    const auto l = encode_labels(*f.labels);
    out.insert(out.end(), l.begin(), l.end());
  }
  return out;
}

}  // namespace pvcap::sensel
