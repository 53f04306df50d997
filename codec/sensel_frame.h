#pragma once
// One Sensel Morph frame as it comes off the wire (protocol spec §5): the
// payload of a 0x26 frame read. parse_frame() accepts a payload only when every
// section is complete and every byte is used; anything else is rejected with
// the reason, never half-used. encode_frame() is its exact inverse.
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "codec/sensel_pressure_codec.h"
#include "core/result.h"

namespace pvcap::sensel {

enum Content : std::uint8_t { kPressure = 0x01, kLabels = 0x02, kContacts = 0x04, kAccel = 0x08 };
enum ContactGroup : std::uint8_t { kEllipse = 0x01, kDeltas = 0x02, kBoundingBox = 0x04, kPeak = 0x08 };

struct Contact {
  std::uint8_t id = 0;
  std::uint8_t state = 0;                                    // 0 invalid, 1 start, 2 move, 3 end
  std::uint16_t x = 0, y = 0;                                // /256 mm
  std::uint16_t total_force = 0;                             // /8 g
  std::uint16_t area = 0;                                    // sensels
  std::int16_t orientation = 0;                              // /16 deg   (ellipse)
  std::uint16_t major = 0, minor = 0;                        // /256 mm (ellipse)
  std::int16_t dx = 0, dy = 0, dforce = 0, darea = 0;        // deltas
  std::uint16_t min_x = 0, min_y = 0, max_x = 0, max_y = 0;  // bounding box, /256 mm
  std::uint16_t peak_x = 0, peak_y = 0, peak_force = 0;      // peak
  bool operator==(const Contact&) const = default;
};

struct Accel {
  std::int16_t x = 0, y = 0, z = 0;  // ~15600 counts per g
  bool operator==(const Accel&) const = default;
};

struct Frame {
  std::uint8_t content = 0;         // which sections this frame carries (Content bits)
  std::uint8_t counter = 0;         // rolling, mod 256
  std::uint32_t timestamp_us = 0;   // device clock, free-running, wraps every ~71.6 min
  std::uint8_t contact_groups = 0;  // ContactGroup bits present per contact
  std::vector<Contact> contacts;
  std::optional<Accel> accel;
  std::optional<PressureImage> pressure;
  std::optional<std::vector<std::uint8_t>> labels;
};

// 8-bit sum of the payload bytes (what the device appends).
std::uint8_t checksum(std::span<const std::uint8_t> payload);

Result<Frame> parse_frame(std::span<const std::uint8_t> payload, const Grid& grid);
std::vector<std::uint8_t> encode_frame(const Frame& frame);

}  // namespace pvcap::sensel
