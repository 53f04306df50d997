#pragma once
// One camera frame as pvcap's pipeline sees it: what the camera said (frame id,
// device timestamp, status), when pvcap received it (host CLOCK_MONOTONIC), and
// the pixels, borrowed from the driver's buffer pool until the lease is dropped.
#include <cstdint>
#include <functional>
#include <string>

#include "core/time.h"

namespace pvcap {

enum class FrameStatus : std::uint8_t {
  Good = 0,         // complete, stored when kept
  Incomplete = 1,   // missing packets, timeout, size mismatch: never stored as good
  QueueFull = 2,    // complete, but pvcap's queue was full: pixels released unseen
};
const char* to_string(FrameStatus status);

// Returns a borrowed buffer to its pool when destroyed. Move-only.
class BufferLease {
 public:
  BufferLease() = default;
  explicit BufferLease(std::function<void()> release) : release_(std::move(release)) {}
  BufferLease(BufferLease&& o) noexcept : release_(std::move(o.release_)) { o.release_ = nullptr; }
  BufferLease& operator=(BufferLease&& o) noexcept {
    if (this != &o) {
      reset();
      release_ = std::move(o.release_);
      o.release_ = nullptr;
    }
    return *this;
  }
  BufferLease(const BufferLease&) = delete;
  BufferLease& operator=(const BufferLease&) = delete;
  ~BufferLease() { reset(); }
  void reset() {
    if (release_) release_();
    release_ = nullptr;
  }
  explicit operator bool() const { return bool(release_); }

 private:
  std::function<void()> release_;
};

struct CameraFrame {
  int camera = 0;                 // index in the rig config
  std::uint32_t connection = 0;   // increments on each (re)connection: frame ids restart
  std::uint64_t frame_id = 0;     // as the camera sent it (16-bit on GigE Vision 1.x)
  DeviceNs device_ts;             // the camera's timestamp, as converted by Aravis to ns
  HostNs host_ts;                 // pvcap's arrival stamp (CLOCK_MONOTONIC)
  std::int64_t aravis_system_ns = 0;  // Aravis' own wall-clock arrival stamp, kept for diagnosis
  FrameStatus status = FrameStatus::Good;
  std::string detail;             // why, when status is not Good
  std::uint32_t pixel_format = 0; // PFNC code
  int width = 0;
  int height = 0;
  const std::uint8_t* data = nullptr;  // valid while `lease` is held
  std::size_t size = 0;
  BufferLease lease;
};

}  // namespace pvcap
