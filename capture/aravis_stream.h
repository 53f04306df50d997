#pragma once
// One GVSP stream of one camera connection: its buffer pool and the callback
// that runs on Aravis' stream thread.
//
// Thread rules (as in arvstream.h): `on_new_buffer` runs on Aravis' stream
// thread and does four things only: stamp the arrival time, give the frame its
// sequence (frame_sequencer.h), push it into the bounded queue (without
// waiting), report settled losses; then return. Buffers go back to the pool
// when the consumer drops the frame's lease, from any thread. The object stays
// alive while any lease is out (leases hold a shared_ptr), so a reconnection
// can replace the stream while old frames are still being encoded.
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

#include <arv.h>

#include "capture/aravis_handles.h"
#include "capture/camera_frame.h"
#include "capture/frame_sequencer.h"
#include "core/bounded_queue.h"
#include "core/result.h"

namespace pvcap {

class AravisStream : public std::enable_shared_from_this<AravisStream> {
 public:
  // Creates the stream on `camera` with `buffer_count` buffers of `payload` bytes. Frames go
  // to `queue` stamped with `camera_index` and `connection`; frames lost, with their reason,
  // to `losses`.
  static Result<std::shared_ptr<AravisStream>> create(ArvCamera* camera, int camera_index, std::uint32_t connection,
                                                      std::size_t payload, std::size_t buffer_count, bool packet_resend,
                                                      int socket_buffer_bytes, BoundedQueue<CameraFrame>& queue,
                                                      BoundedQueue<FrameLoss>& losses);
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
  // Stops callbacks from pushing further frames and waits for a running callback to
  // finish, so none can take a new reference afterwards (leases still return buffers);
  // then reports every gap still open. Call before dropping the last owner reference.
  void quiesce();
  // Reports the losses settled by `now` (the control thread calls it, so a silent camera's
  // gaps are reported too).
  void settle_losses(HostNs now, bool all = false);
  StreamCounters counters() const;
  HostNs last_arrival() const { return HostNs{last_arrival_ns_.load(std::memory_order_relaxed)}; }

 private:
  AravisStream(BoundedQueue<CameraFrame>& queue, BoundedQueue<FrameLoss>& losses, int camera_index,
               std::uint32_t connection)
      : queue_(queue), losses_(losses), camera_index_(camera_index), connection_(connection), sequencer_(connection) {}
  static void on_new_buffer(ArvStream* stream, void* self);
  static void on_stream_event(void* self, ArvStreamCallbackType type, ArvBuffer* buffer);
  // True once Aravis' stream thread waits for packets with no frame half-assembled.
  bool stream_thread_idle() const;
  void handle(ArvBuffer* buffer);

  arv::GPtr<ArvStream> stream_;
  BoundedQueue<CameraFrame>& queue_;
  BoundedQueue<FrameLoss>& losses_;
  const int camera_index_;
  const std::uint32_t connection_;
  std::atomic<bool> accepting_{false};  // from accept_from_now() until quiesce()
  std::int64_t created_ns_ = 0;
  std::atomic<int> in_callback_{0};
  std::atomic<std::int64_t> last_arrival_ns_{0};
  std::atomic<int> stream_tid_{0};                 // Aravis' stream thread (its INIT event)
  std::atomic<std::uint64_t> frames_started_{0};   // frames the stream thread began to assemble
  std::atomic<std::uint64_t> frames_finished_{0};  // ... and completed or gave up
  std::atomic<std::uint64_t> overflows_{0};
  FrameSequencer sequencer_;
  std::mutex settle_mu_;               // settle_losses() runs on the stream and the control thread
  std::vector<FrameLoss> unreported_;  // settled, not yet taken by the losses queue
  gulong signal_id_ = 0;
};

}  // namespace pvcap
