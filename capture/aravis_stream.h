#pragma once
// One GVSP stream of one camera connection: its buffer pool, the arrival stamp
// of each buffer, and the frames taken from Aravis' own output queue.
//
// Thread rules (as in arvstream.h): Aravis' stream thread reassembles frames,
// puts each finished buffer in its output queue (waking the consumer) and calls
// `on_stream_event`, which only stamps the buffer's arrival time into its slot
// (the buffer's user data) and returns. The consumer's thread takes
// frames with `take_frame`: it builds the frame, gives it its sequence
// (frame_sequencer.h) and reports settled losses. No signal, no second queue,
// nothing else on the stream thread: the bare receive loop's path
// (docs/performance-log.md, "Capture path"). Buffers go back to the pool when the
// consumer drops the frame's lease, from any thread. The object stays alive
// while any lease is out (leases hold a shared_ptr), so a reconnection can
// replace the stream while old frames are still being encoded.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <utility>
#include <vector>

#include <arv.h>

#include "capture/aravis_chunks.h"
#include "capture/aravis_handles.h"
#include "capture/arrival_slot.h"
#include "capture/camera_frame.h"
#include "capture/frame_sequencer.h"
#include "core/bounded_queue.h"
#include "core/result.h"

namespace pvcap {

// What the camera was configured to send: a complete frame of another size or pixel format is not its
// own (0: not checked).
struct ExpectedImage {
  int width = 0, height = 0;
  std::uint32_t pixel_format = 0;  // PFNC
};

// How a stream receives its camera's packets. Aravis' packet socket (the default where raw sockets
// are allowed: root, CAP_NET_RAW) costs the least CPU, but from its making until its filter is
// attached it takes every packet on the interface: made while another camera streams, it can
// assemble that camera's frame as its own, size and format alike when the cameras are identical.
// A UDP socket of its own takes only what is sent to its own port: no other camera's frame can reach
// it (it needs a receive buffer of a few frames: net.core.rmem_max, which preflight checks).
enum class StreamSocket { Packet, OwnPort };

class AravisStream : public std::enable_shared_from_this<AravisStream> {
 public:
  // Creates the stream on `camera` with `buffer_count` buffers of `payload` bytes. Frames are
  // stamped with `camera_index` and `connection`; frames lost, with their reason, go to `losses`.
  // A complete frame that is not `expected` is handed over as incomplete and FrameIdentity::Foreign
  // (detail: its size and format), its pixels never (a runtime guard: another camera's packets reaching this stream, by
  // a packet socket before its filter or a camera sending to the wrong port, would otherwise be stored as this camera's
  // picture). With `chunks`, each good frame carries what its chunk data says (the image is then the
  // buffer's first bytes: `expected` gives their count).
  static Result<std::shared_ptr<AravisStream>> create(ArvCamera* camera, int camera_index, std::uint32_t connection,
                                                      std::size_t payload, std::size_t buffer_count, bool packet_resend,
                                                      int socket_buffer_bytes, BoundedQueue<FrameLoss>& losses,
                                                      const ExpectedImage& expected = {},
                                                      std::shared_ptr<const AravisChunks> chunks = nullptr,
                                                      StreamSocket socket = StreamSocket::Packet);
  ~AravisStream();
  AravisStream(const AravisStream&) = delete;
  AravisStream& operator=(const AravisStream&) = delete;

  // Frames are taken from now on; what the stream assembled before is not this camera's (it is not
  // acquiring yet) and is dropped. Call right before AcquisitionStart; waits until the stream is
  // kSettleNs old and its thread has assembled or given up all it received (see the definition
  // for why), at most kMaxSettleNs.
  void accept_from_now();
  static constexpr std::int64_t kSettleNs = 250'000'000;
  static constexpr std::int64_t kMaxSettleNs = 3'000'000'000;
  // The consumer's side (one thread at a time): the next frame Aravis finished, waiting up to
  // `timeout` for one; none when the wait ran out. Buffers finished before accept_from_now() or
  // after quiesce() go straight back to the pool.
  std::optional<CameraFrame> take_frame(std::chrono::microseconds timeout);
  // Stops frames from being taken from buffers finished from now on, and waits for a running
  // stamp to finish. Frames finished before stay in Aravis' queue for take_frame.
  void quiesce();
  // The camera stopped answering: when the last frame leased from this stream goes, the stream is
  // finalized in the background (arv::release_in_background says why), not on that frame's thread.
  void device_unreachable() { device_unreachable_.store(true); }
  // After quiesce(): true once take_frame has taken every frame finished before it (the consumer
  // then reports the last gaps with settle_losses(now, true)).
  bool drained() const;
  // Reports the losses settled by `now` (the control thread calls it, so a silent camera's
  // gaps are reported too).
  void settle_losses(HostNs now, bool all = false);
  StreamCounters counters() const;
  HostNs last_arrival() const { return HostNs{last_arrival_ns_.load(std::memory_order_relaxed)}; }

 private:
  AravisStream(BoundedQueue<FrameLoss>& losses, int camera_index, std::uint32_t connection, std::size_t buffer_count)
      : losses_(losses),
        camera_index_(camera_index),
        connection_(connection),
        arrivals_(buffer_count),
        sequencer_(connection) {}
  static void on_stream_event(void* self, ArvStreamCallbackType type, ArvBuffer* buffer);
  static void destroy(AravisStream* stream);  // the shared_ptr's deleter
  // True once Aravis' stream thread waits for packets with no frame half-assembled.
  bool stream_thread_idle() const;
  void stamp(ArvBuffer* buffer);
  // The arrival of the fill just taken (arrival_slot.h); a buffer without a slot has none: now, late.
  ArrivalSlot::Arrival arrival_of(ArvBuffer* buffer);
  void give_back(ArvBuffer* buffer);
  bool own_image(ArvBuffer* buffer) const;  // its size and pixel format are what the camera was set to send
  CameraFrame frame_of(ArvBuffer* buffer, HostNs arrival);

  arv::GPtr<ArvStream> stream_;
  BoundedQueue<FrameLoss>& losses_;
  const int camera_index_;
  const std::uint32_t connection_;
  ExpectedImage expected_;
  std::shared_ptr<const AravisChunks> chunks_;
  std::atomic<bool> accepting_{false};  // from accept_from_now() until quiesce()
  std::atomic<bool> quiesced_{false};
  std::atomic<bool> device_unreachable_{false};
  std::int64_t created_ns_ = 0;
  std::vector<ArrivalSlot> arrivals_;  // one per buffer, its user data; sized once, never moved
  std::atomic<int> in_callback_{0};
  std::atomic<std::uint64_t> accepted_{0};   // buffers stamped while accepting
  std::atomic<std::uint64_t> delivered_{0};  // ... and taken by take_frame
  std::atomic<std::int64_t> last_arrival_ns_{0};
  std::atomic<int> stream_tid_{0};                 // Aravis' stream thread (its INIT event)
  std::atomic<std::uint64_t> frames_started_{0};   // frames the stream thread began to assemble
  std::atomic<std::uint64_t> frames_finished_{0};  // ... and completed or gave up
  FrameSequencer sequencer_;
  std::mutex settle_mu_;               // settle_losses() runs on the consumer's and the control thread
  std::vector<FrameLoss> unreported_;  // settled, not yet taken by the losses queue
};

}  // namespace pvcap
