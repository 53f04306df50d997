#pragma once
// One camera frame as pvcap's pipeline sees it: what the camera said (frame id,
// device timestamp, status), when pvcap received it (host CLOCK_MONOTONIC), and
// the pixels, borrowed from the driver's buffer pool until the lease is dropped.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "core/time.h"

namespace pvcap {

enum class FrameStatus : std::uint8_t {
  Good = 0,        // complete, stored when kept
  Incomplete = 1,  // missing packets, timeout, size mismatch: never stored as good
  QueueFull = 2,   // complete, but pvcap's queue was full: pixels released unseen
};
const char* to_string(FrameStatus status);

// Whether a buffer is the frame its id and timestamp name.
enum class FrameIdentity : std::uint8_t {
  Own = 0,            // a new frame, or one that arrived late into a gap
  NoFrameId = 1,      // no leader packet: no id, no timestamp (GigE Vision never sends id 0)
  Duplicate = 2,      // a complete frame with an id already received
  StaleMetadata = 3,  // incomplete, carrying its buffer's previous frame's id and timestamp
  Foreign = 4,        // another camera's frame (not the size or pixel format this one sends): not in its sequence
};

// Returns a borrowed buffer to its pool when destroyed. Move-only. Built on the capture thread
// once per frame, so it allocates nothing: a plain function, the pool (kept alive) and the buffer.
class BufferLease {
 public:
  using Release = void (*)(void* pool, void* buffer);
  BufferLease() = default;
  BufferLease(Release release, std::shared_ptr<void> pool, void* buffer)
      : release_(release), pool_(std::move(pool)), buffer_(buffer) {}
  BufferLease(BufferLease&& o) noexcept
      : release_(std::exchange(o.release_, nullptr)), pool_(std::move(o.pool_)), buffer_(o.buffer_) {}
  BufferLease& operator=(BufferLease&& o) noexcept {
    if (this != &o) {
      reset();
      release_ = std::exchange(o.release_, nullptr);
      pool_ = std::move(o.pool_);
      buffer_ = o.buffer_;
    }
    return *this;
  }
  BufferLease(const BufferLease&) = delete;
  BufferLease& operator=(const BufferLease&) = delete;
  ~BufferLease() { reset(); }
  void reset() {
    if (release_) release_(pool_.get(), buffer_);
    release_ = nullptr;
    pool_.reset();
  }
  explicit operator bool() const { return release_ != nullptr; }

 private:
  Release release_ = nullptr;
  std::shared_ptr<void> pool_;
  void* buffer_ = nullptr;
};

// A frame's own state as the camera reported it in the frame's chunk data (GenICam chunks: a camera
// with chunk mode on appends them to the image); each absent where the camera sent none.
struct FrameChunks {
  std::optional<std::uint64_t> frame_counter;  // the camera's own count (ChunkFrameID, ...)
  std::optional<std::int64_t> timestamp;       // its timestamp, in the camera's ticks (ns on SFNC 2)
  std::optional<double> exposure_us;           // the exposure this frame had
  std::optional<double> gain;                  // its gain, in the camera's unit (dB on SFNC 2)
  std::optional<std::int64_t> line_status;     // its lines' levels, bit N for LineN (ChunkLineStatusAll)
};

struct CameraFrame {
  int camera = 0;                     // index in the rig config
  std::uint32_t connection = 0;       // increments on each (re)connection: frame ids restart
  std::uint64_t frame_id = 0;         // as the camera sent it (16-bit on GigE Vision 1.x)
  DeviceNs device_ts;                 // the camera's timestamp, as converted by Aravis to ns
  HostNs host_ts;                     // pvcap's arrival stamp (CLOCK_MONOTONIC)
  bool arrival_late = false;          // its stamp came > 2 ms after Aravis queued it: host_ts is its take
  std::int64_t aravis_system_ns = 0;  // Aravis' own wall-clock arrival stamp, kept for diagnosis
  FrameStatus status = FrameStatus::Good;
  // The frame's place in the camera's numbering (set by the driver, see frame_sequencer.h):
  // its id unwrapped within the connection (0: unknown), and how many ids were skipped just
  // before it (what became of them is reported separately, as losses with their reason).
  std::uint64_t sequence = 0;
  std::uint64_t lost_before = 0;
  FrameIdentity identity = FrameIdentity::Own;
  std::string detail;              // why, when status is not Good
  std::uint32_t pixel_format = 0;  // PFNC code
  int width = 0;
  int height = 0;
  const std::uint8_t* data = nullptr;  // valid while `lease` is held
  std::size_t size = 0;                // the image's bytes (without any chunk data after them)
  FrameChunks chunks;
  // Added to device_ts for the image's instant beyond the camera's constant stamp-to-instant offset:
  // half the difference of the frame's own exposure (its chunks) from the one read back; 0 without.
  std::int64_t instant_correction_ns = 0;
  BufferLease lease;
};

// A camera stream's tallies (Aravis' own counters and pvcap's queue drops), summed over connections.
struct StreamCounters {
  std::uint64_t completed = 0;  // Aravis: buffers completed
  std::uint64_t failures = 0;   // Aravis: buffers failed (missing packets, timeouts)
  std::uint64_t underruns = 0;  // Aravis: frames arriving with no free buffer
  std::uint64_t resent_packets = 0;
  std::uint64_t missing_packets = 0;
  std::uint64_t queue_overflows = 0;  // pvcap: frames dropped because the queue was full
  StreamCounters& operator+=(const StreamCounters& o);
};

}  // namespace pvcap
