#include "capture/aravis_stream.h"

#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <string>
#include <thread>

#include <fmt/format.h>

#include "codec/pixel_format.h"

namespace pvcap {

StreamCounters& StreamCounters::operator+=(const StreamCounters& o) {
  completed += o.completed;
  failures += o.failures;
  underruns += o.underruns;
  resent_packets += o.resent_packets;
  missing_packets += o.missing_packets;
  queue_overflows += o.queue_overflows;
  return *this;
}

Result<std::shared_ptr<AravisStream>> AravisStream::create(ArvCamera* camera, int camera_index,
                                                           std::uint32_t connection, std::size_t payload,
                                                           std::size_t buffer_count, bool packet_resend,
                                                           int socket_buffer_bytes, BoundedQueue<FrameLoss>& losses,
                                                           const ExpectedImage& expected,
                                                           std::shared_ptr<const AravisChunks> chunks,
                                                           StreamSocket socket) {
  std::shared_ptr<AravisStream> self(new AravisStream(losses, camera_index, connection, buffer_count),
                                     &AravisStream::destroy);
  self->expected_ = expected;
  self->chunks_ = std::move(chunks);
  arv::GErrorSlot err;
  self->created_ns_ = host_now().ns;
  // The options are the device's and read when its stream is made: set for this stream each time.
  if (ArvDevice* device = arv_camera_get_device(camera); ARV_IS_GV_DEVICE(device))
    arv_gv_device_set_stream_options(ARV_GV_DEVICE(device), socket == StreamSocket::OwnPort
                                                                ? ARV_GV_STREAM_OPTION_PACKET_SOCKET_DISABLED
                                                                : ARV_GV_STREAM_OPTION_NONE);
  self->stream_.reset(arv_camera_create_stream(camera, &AravisStream::on_stream_event, self.get(), err.out()));
  if (!self->stream_) return Error{fmt::format("cannot create the video stream: {}", err.message())};
  if (ARV_IS_GV_STREAM(self->stream_.get())) {
    g_object_set(self->stream_.get(), "packet-resend",
                 packet_resend ? ARV_GV_STREAM_PACKET_RESEND_ALWAYS : ARV_GV_STREAM_PACKET_RESEND_NEVER, nullptr);
    // A UDP socket holds what arrives while the stream thread waits for the CPU: at least four frames
    // (the kernel caps it at net.core.rmem_max).
    const std::size_t own_port_floor = socket == StreamSocket::OwnPort ? 4 * payload : 0;
    const auto bytes = std::max<std::size_t>(std::size_t(std::max(socket_buffer_bytes, 0)), own_port_floor);
    if (bytes > 0)
      g_object_set(self->stream_.get(), "socket-buffer", ARV_GV_STREAM_SOCKET_BUFFER_FIXED, "socket-buffer-size",
                   int(std::min<std::size_t>(bytes, 1u << 30)), nullptr);
  }
  for (std::size_t i = 0; i < buffer_count; ++i) {
    ArvBuffer* buffer = arv_buffer_new_full(payload, nullptr, &self->arrivals_[i], nullptr);
    // Touched now, before the camera acquires: the first write into a fresh buffer page-faults it
    // in, 2-7 ms for 2 MB on the project's VMs, and that would fall on the stream thread while it
    // reassembles the first second's frames (docs/performance-log.md, "The first second").
    std::size_t size = 0;
    if (void* data = const_cast<void*>(arv_buffer_get_data(buffer, &size))) std::memset(data, 0, size);
    arv_stream_push_buffer(self->stream_.get(), buffer);
  }
  return self;
}

AravisStream::~AravisStream() {
  if (!stream_) return;
  accepting_.store(false);
  // Joins Aravis' stream thread and frees the buffers: no lease is out by now.
  stream_.reset();
}

void AravisStream::destroy(AravisStream* stream) {
  if (stream->device_unreachable_.load())
    arv::release_in_background([stream] { delete stream; });
  else
    delete stream;
}

void AravisStream::accept_from_now() {
  // Aravis' packet-socket receiver (used when raw sockets are allowed: root, CAP_NET_RAW) takes every
  // packet on the interface from the moment its socket is made until its filter is attached, so a
  // stream made while another camera streams (a reconnection) can assemble that camera's frames as
  // its own (test_stream_isolation: 2-6 such frames in 30-40 streams). They are all there by the time the stream
  // exists, and its thread assembles them at once, or gives an incomplete one up after its frame
  // retention (100 ms). So: nothing before the camera is told to acquire, and that not before the
  // stream is kSettleNs old. (A UDP socket instead needs a receive buffer of several frames, which
  // Linux's default limit of 208 KiB does not allow: 9 of 450 1080p frames came through.)
  // Age alone is not enough on a loaded machine: a stream thread that gets the CPU late assembles
  // them late (a suite run on 2 cores: 4 foreign frames in 30 streams). So also until the thread
  // sleeps in poll() with no frame half-assembled: the kernel hands it the ring block holding the
  // stale packets once the block is 5 ms old (without the age, the check alone let 2-7 frames in,
  // each 7-14 ms after its stream was made), and poll() does not sleep while that block is unread.
  // Left: a kernel whose timers run that block's retirement later than kSettleNs.
  const std::int64_t deadline = created_ns_ + kMaxSettleNs;
  for (;;) {
    const std::int64_t now = host_now().ns;
    if (now >= deadline) break;
    if (now >= created_ns_ + kSettleNs && stream_thread_idle()) break;
    const std::int64_t nap = std::max<std::int64_t>(created_ns_ + kSettleNs - now, 5'000'000);
    std::this_thread::sleep_for(std::chrono::nanoseconds(std::min(nap, deadline - now)));
  }
  accepting_.store(true);
}

void AravisStream::on_stream_event(void* self_ptr, ArvStreamCallbackType type, ArvBuffer* buffer) {
  auto* self = static_cast<AravisStream*>(self_ptr);
  if (type == ARV_STREAM_CALLBACK_TYPE_INIT) {
    self->stream_tid_.store(int(::syscall(SYS_gettid)));
  } else if (type == ARV_STREAM_CALLBACK_TYPE_START_BUFFER) {
    self->frames_started_.fetch_add(1, std::memory_order_relaxed);
  } else if (type == ARV_STREAM_CALLBACK_TYPE_BUFFER_DONE) {
    if (buffer) self->stamp(buffer);
    self->frames_finished_.fetch_add(1, std::memory_order_relaxed);
  }
}

// Runs on Aravis' stream thread as it finishes a buffer: the arrival, and whether the frame is taken.
void AravisStream::stamp(ArvBuffer* buffer) {
  in_callback_.fetch_add(1);
  const HostNs arrival = host_now();
  last_arrival_ns_.store(arrival.ns, std::memory_order_relaxed);
  if (auto* slot = static_cast<ArrivalSlot*>(const_cast<void*>(arv_buffer_get_user_data(buffer)))) {
    // Sequentially consistent, as in_callback_ and quiesce()'s store are: a stamp quiesce() did not
    // wait for sees it (a plain load on x86).
    const bool accepted = accepting_.load();
    slot->stamp(arrival, accepted);
    if (accepted) accepted_.fetch_add(1, std::memory_order_relaxed);
  }
  in_callback_.fetch_sub(1);
}

ArrivalSlot::Arrival AravisStream::arrival_of(ArvBuffer* buffer) {
  auto* slot = static_cast<ArrivalSlot*>(const_cast<void*>(arv_buffer_get_user_data(buffer)));
  if (!slot) return {host_now(), accepting_.load(), true};
  // Queued before its callback, a buffer is stamped within microseconds: the stream thread runs the
  // callback next. 2 ms covers a stream thread preempted in between.
  return slot->take(std::chrono::milliseconds(2), accepting_);
}

bool AravisStream::stream_thread_idle() const {
  if (frames_started_.load() != frames_finished_.load()) return false;
  const int tid = stream_tid_.load();
  if (tid == 0) return true;  // no INIT seen: nothing to wait for
  // The thread's state, the field after the command name: 'S' while it sleeps in poll().
  std::ifstream in("/proc/self/task/" + std::to_string(tid) + "/stat");
  std::string stat;
  std::getline(in, stat);
  const auto name_end = stat.rfind(')');
  if (name_end == std::string::npos || name_end + 2 >= stat.size()) return true;  // gone, or unreadable
  return stat[name_end + 2] == 'S';
}

void AravisStream::quiesce() {
  accepting_.store(false);
  while (in_callback_.load() > 0) std::this_thread::yield();
  quiesced_.store(true);
}

bool AravisStream::drained() const { return quiesced_.load() && delivered_.load() >= accepted_.load(); }

void AravisStream::settle_losses(HostNs now, bool all) {
  if (!all && !sequencer_.has_due(now)) return;
  std::lock_guard lock(settle_mu_);
  guint64 underruns = 0;
  arv_stream_get_statistics(stream_.get(), nullptr, nullptr, &underruns);
  sequencer_.settle(now, underruns, unreported_, all);
  // A full losses queue keeps them here until the consumer makes room: none is dropped.
  std::size_t sent = 0;
  while (sent < unreported_.size() && losses_.try_push(unreported_[sent])) ++sent;
  unreported_.erase(unreported_.begin(), unreported_.begin() + std::ptrdiff_t(sent));
}

void AravisStream::give_back(ArvBuffer* buffer) { arv_stream_push_buffer(stream_.get(), buffer); }

std::optional<CameraFrame> AravisStream::take_frame(std::chrono::microseconds timeout) {
  const std::int64_t deadline = host_now().ns + std::chrono::nanoseconds(timeout).count();
  for (;;) {
    const std::int64_t left_us = std::max<std::int64_t>(0, (deadline - host_now().ns) / 1000);
    ArvBuffer* buffer = left_us > 0 ? arv_stream_timeout_pop_buffer(stream_.get(), guint64(left_us))
                                    : arv_stream_try_pop_buffer(stream_.get());
    if (!buffer) return std::nullopt;
    const ArrivalSlot::Arrival arrived = arrival_of(buffer);
    if (!arrived.accepted) {
      give_back(buffer);
      continue;
    }
    CameraFrame frame = frame_of(buffer, arrived.at);
    frame.arrival_late = arrived.late;
    delivered_.fetch_add(1);
    sequencer_.identify(frame);
    settle_losses(host_now());
    return frame;
  }
}

CameraFrame AravisStream::frame_of(ArvBuffer* buffer, HostNs arrival) {
  CameraFrame frame;
  frame.camera = camera_index_;
  frame.connection = connection_;
  frame.frame_id = arv_buffer_get_frame_id(buffer);
  frame.device_ts = DeviceNs{std::int64_t(arv_buffer_get_timestamp(buffer))};
  frame.host_ts = arrival;
  frame.aravis_system_ns = std::int64_t(arv_buffer_get_system_timestamp(buffer));
  const ArvBufferStatus status = arv_buffer_get_status(buffer);
  if (status == ARV_BUFFER_STATUS_SUCCESS && !own_image(buffer)) {
    frame.status = FrameStatus::Incomplete;
    frame.identity = FrameIdentity::Foreign;
    frame.detail = fmt::format("{}x{}_{:#x}", arv_buffer_get_image_width(buffer), arv_buffer_get_image_height(buffer),
                               std::uint32_t(arv_buffer_get_image_pixel_format(buffer)));
    give_back(buffer);
    return frame;
  }
  if (status == ARV_BUFFER_STATUS_SUCCESS) {
    frame.status = FrameStatus::Good;
    frame.pixel_format = arv_buffer_get_image_pixel_format(buffer);
    frame.width = arv_buffer_get_image_width(buffer);
    frame.height = arv_buffer_get_image_height(buffer);
    frame.data = static_cast<const std::uint8_t*>(arv_buffer_get_image_data(buffer, &frame.size));
    if (chunks_ && arv_buffer_has_chunks(buffer)) {
      // Aravis counts the chunks after the image as its data too: the image is what the region holds.
      const std::size_t image = image_bytes(frame.width, frame.height, frame.pixel_format);
      if (image > 0 && image < frame.size) frame.size = image;
      frame.chunks = chunks_->read(buffer);
      frame.instant_correction_ns = chunks_->instant_correction_ns(frame.chunks);
    }
    frame.lease = BufferLease(
        [](void* pool, void* buf) { static_cast<AravisStream*>(pool)->give_back(static_cast<ArvBuffer*>(buf)); },
        shared_from_this(), buffer);
    return frame;
  }
  frame.status = FrameStatus::Incomplete;
  switch (status) {
    case ARV_BUFFER_STATUS_MISSING_PACKETS:
      frame.detail = "missing_packets";
      break;
    case ARV_BUFFER_STATUS_TIMEOUT:
      frame.detail = "timeout";
      break;
    case ARV_BUFFER_STATUS_SIZE_MISMATCH:
      frame.detail = "size_mismatch";
      break;
    case ARV_BUFFER_STATUS_ABORTED:
      frame.detail = "aborted";
      break;
    case ARV_BUFFER_STATUS_WRONG_PACKET_ID:
      frame.detail = "wrong_packet_id";
      break;
    case ARV_BUFFER_STATUS_CLEARED:
      frame.detail = "cleared";
      break;
    default:
      frame.detail = "failed";
      break;
  }
  give_back(buffer);
  return frame;
}

bool AravisStream::own_image(ArvBuffer* buffer) const {
  if (expected_.width <= 0) return true;
  return arv_buffer_get_image_width(buffer) == expected_.width &&
         arv_buffer_get_image_height(buffer) == expected_.height &&
         (expected_.pixel_format == 0 ||
          std::uint32_t(arv_buffer_get_image_pixel_format(buffer)) == expected_.pixel_format);
}

StreamCounters AravisStream::counters() const {
  StreamCounters c;
  guint64 completed = 0, failures = 0, underruns = 0;
  arv_stream_get_statistics(stream_.get(), &completed, &failures, &underruns);
  c.completed = completed;
  c.failures = failures;
  c.underruns = underruns;
  if (ARV_IS_GV_STREAM(stream_.get())) {
    guint64 resent = 0, missing = 0;
    arv_gv_stream_get_statistics(ARV_GV_STREAM(stream_.get()), &resent, &missing);
    c.resent_packets = resent;
    c.missing_packets = missing;
  }
  return c;  // queue_overflows stays 0: frames wait in Aravis' own queue, holding their buffers
}

}  // namespace pvcap
