#include "sim/sim_camera.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>

#include <cstring>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "capture/gige_vision_wire.h"
#include "codec/pixel_format.h"
#include "core/time.h"
#include "sim/board_motion.h"
#include "sim/camera_views.h"
#include "sim/fake_camera_features.h"
#include "sim/fingertip.h"
#include "sim/hand.h"
#include "sim/lights.h"
#include "sim/scene.h"
#include "sim/scene_cache.h"
#include "sim/timecode.h"

namespace pvcap::sim {

namespace {
// Everything the scene's render reads besides the code (sim/scene_cache.h): the camera's model,
// exactly (hexadecimal floats), and the pixel format.
std::string scene_key(const calib::CameraModel& m, const std::string& pixel_format) {
  std::string key = fmt::format("pad scene, {} {}x{}\nK", pixel_format, m.image_size.width, m.image_size.height);
  for (double v : m.K.val) key += fmt::format(" {:a}", v);
  key += "\ndistortion";
  for (double v : m.distortion) key += fmt::format(" {:a}", v);
  key += "\nR";
  for (double v : m.R.val) key += fmt::format(" {:a}", v);
  key += "\nt";
  for (double v : m.t.val) key += fmt::format(" {:a}", v);
  return key + "\n";
}
}  // namespace

Result<std::unique_ptr<SimCamera>> SimCamera::create(int index, const CameraConfig& camera, const SimCameraClock& clock,
                                                     std::int64_t t0_ns, std::uint64_t seed,
                                                     const std::filesystem::path& truth_dir,
                                                     std::shared_ptr<const Hand> hand, bool board,
                                                     std::shared_ptr<SimLights> lights) {
  if (camera.address.empty())
    return Error{fmt::format("{}: a simulated camera needs an 'address' (127.0.0.x)", camera.name)};
  std::unique_ptr<SimCamera> self(new SimCamera());
  self->index_ = index;
  self->name_ = camera.name;
  self->config_ = clock;
  self->configured_size_ = cv::Size(camera.width, camera.height);
  self->hand_ = std::move(hand);
  self->board_ = board;
  if (lights && !lights->empty()) self->lights_ = std::move(lights);
  self->clock_ = SimClock{t0_ns, clock.offset_ms * 1e6, clock.drift_ppm * 1e-6, clock.jitter_us * 1e3};
  self->exposure_latency_ns_ = std::int64_t(clock.exposure_latency_ms * 1e6);
  self->undeclared_latency_ns_ = std::int64_t(std::llround(clock.undeclared_latency_ms * 1e6));
  self->rng_.seed(seed * 1000 + std::uint64_t(index));
  const auto truth_path = truth_dir / (camera.name + "_frames.csv");
  const bool fresh = !std::filesystem::exists(truth_path);  // a camera that comes back appends
  self->truth_.open(truth_path, std::ios::app);
  if (!self->truth_) return Error{fmt::format("cannot write ground truth {}", truth_path.string())};
  if (fresh) self->truth_ << "frame_id,true_ns,device_ns,width,height\n";

  const std::string serial = camera.serial.empty() ? fmt::format("PVSIM{}", index) : camera.serial;
  const std::string genicam = fake_camera_genicam(clock.node_map);
  self->fake_.reset(
      arv_gv_fake_camera_new_full(camera.address.c_str(), serial.c_str(), genicam.empty() ? nullptr : genicam.c_str()));
  if (!self->fake_ || !arv_gv_fake_camera_is_running(self->fake_.get()))
    return Error{
        fmt::format("{}: the fake camera could not listen on {} (is the address on an interface? the "
                    "simulated rig runs in its own network namespace)",
                    camera.name, camera.address)};
  self->packet_loss_ = clock.packet_loss;
  if (clock.packet_loss > 0) g_object_set(self->fake_.get(), "gvsp-lost-ratio", clock.packet_loss, nullptr);
  if (clock.node_map == NodeMapNaming::Sfnc2) {  // the map with chunk data: its frames may need our sender
    auto sender = GvspSender::open(camera.address);
    if (!sender) return Error{fmt::format("{}: {}", camera.name, sender.error().message)};
    self->sender_.emplace(std::move(sender.value()));
  }
  if (clock.white_balance_auto)
    arv_fake_camera_write_register(arv_gv_fake_camera_get_fake_camera(self->fake_.get()), kBalanceWhiteAutoRegister, 2);
  // The engine looks for a pending software trigger once per 1/trigger_frequency, at whole periods
  // of the real-time clock: keep that well above the camera's rate so triggered frames are not
  // delayed much by the simulator. (Every engine wakes at the same instants, so cameras on one
  // trigger line expose together. A higher rate costs a core: the engine's poll spins through the
  // last millisecond before each wake.)
  arv_fake_camera_set_trigger_frequency(arv_gv_fake_camera_get_fake_camera(self->fake_.get()),
                                        std::max(100.0, 4 * camera.frame_rate));
  // Render the scene now for the configured format: the first frame must not stall the stream.
  if (const std::uint32_t pf = pixel_format_code(camera.pixel_format)) {
    (void)self->base_image(camera.width, camera.height, ArvPixelFormat(pf));
    // And as every combination of lamps lights it (a first switch must not stall the stream either).
    if (self->lights_ && self->lights_->lamps().size() <= 4)
      for (std::uint32_t lamps = 0; lamps < (1u << self->lights_->lamps().size()); ++lamps)
        (void)self->lit_base(camera.width, camera.height, ArvPixelFormat(pf), lamps);
    if (board) (void)self->board_image(camera.width, camera.height, ArvPixelFormat(pf), t0_ns);
  }
  arv_fake_camera_set_fill_pattern(arv_gv_fake_camera_get_fake_camera(self->fake_.get()), &SimCamera::fill, self.get());
  SimCamera* raw = self.get();
  // Wired to a trigger line pulsing at its configured rate (used when the host picks Line0), unless
  // the rig's simulator says its cable is off.
  serve_features(
      raw, arv_gv_fake_camera_get_fake_camera(raw->fake_.get()),
      [raw](std::int64_t host_ns) { return raw->clock_.device_time(host_ns); },
      clock.trigger_line ? periodic_line(camera.frame_rate) : TriggerLine(), clock.node_map,
      raw->lights_ ? OutputLines([lights = raw->lights_, index](std::uint32_t mask, std::int64_t host_ns) {
        lights->outputs(index, mask, host_ns);
      })
                   : OutputLines(),
      PtpBehaviour{clock.ptp_lock_after_s, clock.ptp_servo_error_ns, clock.ptp_unlock_at_s, clock.ptp_unlock_for_s});
  // Free-running, the engine is late once a frame period and 0.3 ms have passed since it began the
  // last frame; triggered, once a trigger has been pending for a look-for-triggers period and 0.3 ms.
  const std::int64_t trigger_period_ns = std::int64_t(1e9 / std::max(100.0, 4 * camera.frame_rate));
  raw->kicker_ = std::make_unique<EngineKicker>(camera.address, [raw, trigger_period_ns] {
    ArvFakeCamera* fake = arv_gv_fake_camera_get_fake_camera(raw->fake_.get());
    guint32 acquiring = 0, triggered = 0, pending = 0, period_us = 0;
    arv_fake_camera_read_register(fake, ARV_FAKE_CAMERA_REGISTER_ACQUISITION, &acquiring);
    arv_fake_camera_read_register(fake, ARV_FAKE_CAMERA_REGISTER_TRIGGER_MODE, &triggered);
    arv_fake_camera_read_register(fake, ARV_FAKE_CAMERA_REGISTER_TRIGGER_SOFTWARE, &pending);
    arv_fake_camera_read_register(fake, ARV_FAKE_CAMERA_REGISTER_ACQUISITION_FRAME_PERIOD_US, &period_us);
    if (!acquiring) return INT64_MAX;
    if (triggered) {  // the kicker's thread alone keeps when it first saw the trigger pending
      if (!pending) {
        raw->trigger_pending_since_ns_ = 0;
        return INT64_MAX;
      }
      if (raw->trigger_pending_since_ns_ == 0) raw->trigger_pending_since_ns_ = host_now().ns;
      return raw->trigger_pending_since_ns_ + trigger_period_ns + 300'000;
    }
    const std::int64_t last = raw->last_fill_ns_.load();
    if (period_us == 0 || last == 0) return INT64_MAX;
    return last + std::int64_t(period_us) * 1000 + 300'000;
  });
  return self;
}

SimCamera::~SimCamera() {
  kicker_.reset();
  stop_serving(this);
  if (lights_) lights_->outputs(index_, 0, host_now().ns);  // unplugged: its lines go low, its lamps out
  fake_.reset();  // joins the fake camera's thread: no fill runs after this
  std::lock_guard lock(mu_);
  truth_.flush();
}

calib::CameraModel SimCamera::model(cv::Size size) const {
  return sim_camera_model(index_, config_, configured_size_, size);
}

void SimCamera::fill(ArvBuffer* buffer, void* self, guint32 exposure_us, guint32, ArvPixelFormat format) {
  static_cast<SimCamera*>(self)->fill_buffer(buffer, format, std::int64_t(exposure_us) * 1000);
}

const cv::Mat& SimCamera::base_image(int width, int height, ArvPixelFormat format) {
  const auto key = std::make_tuple(width, height, std::uint32_t(format));
  auto it = bases_.find(key);
  if (it == bases_.end()) {
    const std::string pfnc = pixel_format_name(format);
    const calib::CameraModel m = model(cv::Size(width, height));
    cv::Mat image = cached_scene(scene_cache_dir(), scene_key(m, pfnc), [&] {
      return to_sensor_format(render_scene_bgr(calib::default_pad_layout(), m), pfnc);
    });
    it = bases_.emplace(key, std::move(image)).first;
    spdlog::debug("sim {}: the scene at {}x{} {} is ready (rendered, or from sim/scene_cache.h)", name_, width, height,
                  pfnc);
  }
  return it->second;
}

const cv::Mat& SimCamera::lit_base(int width, int height, ArvPixelFormat format, std::uint32_t lamps) {
  if (!lights_) return base_image(width, height, format);
  const auto key = std::make_tuple(width, height, std::uint32_t(format), lamps);
  auto it = lit_.find(key);
  if (it == lit_.end()) {
    auto& shading = shading_[{width, height}];
    if (shading.empty()) shading = lamp_shading(model(cv::Size(width, height)), lights_->lamps());
    it = lit_.emplace(key, lit_image(base_image(width, height, format), shading, lamps)).first;
  }
  return it->second;
}

cv::Mat SimCamera::board_image(int width, int height, ArvPixelFormat format, std::int64_t true_ns) {
  const int pose = board_pose_index(double(true_ns - clock_.t0_ns) * 1e-9);
  auto& view = board_views_[std::make_tuple(width, height, std::uint32_t(format))];
  // Made at start for the configured format; another one a client asks for is made on first use.
  if (!view) view = std::make_unique<BoardFrames>(model({width, height}), pixel_format_name(format), pose);
  return view->frame(pose);
}

// Aravis' engine sends an acquisition's first frame when its idle wait ends, then the others at
// whole multiples of the frame period (of the real-time clock): the first interval came out
// anywhere from 0 to a period (2.8 ms seen), which no free-running camera does, and a recorder
// then has two frames of one camera for one instant. The first frame waits here (at most a period,
// once per acquisition) for the grid's next multiple: the frames after it come a period apart.
void SimCamera::align_first_frame() {
  ArvFakeCamera* fake = arv_gv_fake_camera_get_fake_camera(fake_.get());
  guint32 triggered = 0, period_us = 0;
  arv_fake_camera_read_register(fake, ARV_FAKE_CAMERA_REGISTER_TRIGGER_MODE, &triggered);
  arv_fake_camera_read_register(fake, ARV_FAKE_CAMERA_REGISTER_ACQUISITION_FRAME_PERIOD_US, &period_us);
  if (triggered || period_us == 0) return;
  const std::int64_t last = last_fill_ns_.load();
  const std::int64_t now = host_now().ns;
  if (last != 0 && now - last < 2 * std::int64_t(period_us) * 1000) return;  // streaming
  last_fill_ns_.store(now);  // begun: the kicker does not take this wait for the engine's stall
  const std::int64_t real_us = g_get_real_time();
  std::this_thread::sleep_for(std::chrono::microseconds(period_us - real_us % period_us));
}

// Runs on the fake camera's thread, once per frame, at the frame's capture instant.
void SimCamera::fill_buffer(ArvBuffer* buffer, ArvPixelFormat format, std::int64_t exposure_ns) {
  align_first_frame();
  const std::int64_t true_ns = host_now().ns;
  last_fill_ns_.store(true_ns);
  fill_at(buffer, format, true_ns, exposure_ns);
  // A real camera's frame leaves a constant time after its exposure (exposure, readout: the
  // latency its datasheet states), whatever our rendering took, if it fit in that time.
  if (exposure_latency_ns_ > 0)
    std::this_thread::sleep_until(
        std::chrono::steady_clock::time_point(std::chrono::nanoseconds(true_ns + exposure_latency_ns_)));
  send_with_chunks(buffer, format, exposure_ns);
  if (config_.exposure_wobble_us > 0) wobble_exposure();
}

// The next frame's exposure, the one set plus or minus the wobble, in turn (the engine reads its
// register as it begins a frame). A value the host wrote since is the new one set.
void SimCamera::wobble_exposure() {
  ArvFakeCamera* fake = arv_gv_fake_camera_get_fake_camera(fake_.get());
  guint32 now = 0;
  arv_fake_camera_read_register(fake, ARV_FAKE_CAMERA_REGISTER_EXPOSURE_TIME_US, &now);
  if (now != exposure_written_us_) exposure_set_us_ = now;
  const double next = double(exposure_set_us_) + (wobbled_++ % 2 ? -1.0 : 1.0) * config_.exposure_wobble_us;
  exposure_written_us_ = guint32(std::max(1.0, std::round(next)));
  arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_EXPOSURE_TIME_US, exposure_written_us_);
}

void SimCamera::send_with_chunks(ArvBuffer* buffer, ArvPixelFormat format, std::int64_t exposure_ns) {
  if (!sender_) return;
  ArvFakeCamera* fake = arv_gv_fake_camera_get_fake_camera(fake_.get());
  guint32 chunk_mode = 0, gain = 0, packet_size = 0, line_status = 0;
  arv_fake_camera_read_register(fake, kChunkModeRegister, &chunk_mode);
  if (bool(chunk_mode) != engine_muted_) {  // read by the engine after this fill, for this frame's packets
    engine_muted_ = bool(chunk_mode);
    g_object_set(fake_.get(), "gvsp-lost-ratio", engine_muted_ ? 1.0 : packet_loss_, nullptr);
  }
  if (!chunk_mode) return;
  arv::GPtr<GSocketAddress> to(arv_fake_camera_get_stream_address(fake));
  sockaddr_in destination{};
  if (!to || !g_socket_address_to_native(to.get(), &destination, sizeof destination, nullptr)) return;
  arv_fake_camera_read_register(fake, ARV_FAKE_CAMERA_REGISTER_GAIN_RAW, &gain);
  arv_fake_camera_read_register(fake, kLineStatusRegister, &line_status);
  arv_fake_camera_read_register(fake, gev::stream_packet_size_register(0), &packet_size);
  GvspFrame f;
  f.block_id = std::uint16_t(arv_buffer_get_frame_id(buffer));
  f.timestamp = arv_buffer_get_timestamp(buffer);
  f.pixel_format = std::uint32_t(format);
  f.width = std::uint32_t(arv_buffer_get_image_width(buffer));
  f.height = std::uint32_t(arv_buffer_get_image_height(buffer));
  f.x = std::uint32_t(arv_buffer_get_image_x(buffer));
  f.y = std::uint32_t(arv_buffer_get_image_y(buffer));
  const auto* data = static_cast<const std::uint8_t*>(arv_buffer_get_data(buffer, nullptr));
  if (!data) return;
  f.image = {data, image_bytes(int(f.width), int(f.height), std::uint32_t(format))};
  f.frame_counter = arv_buffer_get_frame_id(buffer);
  f.exposure_us = double(exposure_ns) / 1000.0;
  f.gain = double(gain);
  f.line_status = line_status;
  sender_->send(destination, packet_size & 0xffff, f, packet_loss_);
}

void SimCamera::fill_at(ArvBuffer* buffer, ArvPixelFormat format, std::int64_t true_ns, std::int64_t exposure_ns) {
  std::lock_guard lock(mu_);
  const int width = arv_buffer_get_image_width(buffer);
  const int height = arv_buffer_get_image_height(buffer);
  // arv_buffer_get_data reports the received size, which is 0 while filling; the fake camera
  // has already checked that the allocation holds the payload (width x height x pixel size).
  auto* data = static_cast<std::uint8_t*>(const_cast<void*>(arv_buffer_get_data(buffer, nullptr)));
  const std::uint32_t lamps = lights_ ? lights_->lit_at(true_ns) : 0;
  const cv::Mat base = board_ ? board_image(width, height, format, true_ns) : lit_base(width, height, format, lamps);
  if (!data) return;
  std::memcpy(data, base.data, base.total() * base.elemSize());
  const auto frame_id = std::uint16_t(arv_buffer_get_frame_id(buffer));
  if (hand_ && !board_) {
    const HandPose pose = hand_->pose_at(true_ns - undeclared_latency_ns_);
    if (pose.visible) {
      const calib::CameraModel m = model({width, height});
      const cv::Point2d c = m.project({pose.x_mm, pose.y_mm, 0.0});
      const double r_mm = fingertip_radius_mm(pose.force);
      const cv::Point2d e = m.project({pose.x_mm + r_mm, pose.y_mm, 0.0});
      cv::Mat view(height, width, base.type(), data);
      const double light = lights_ ? light_at(shading_[{width, height}], lamps, c, {width, height}) : 1.0;
      draw_fingertip(view, pixel_format_name(format), c, std::hypot(e.x - c.x, e.y - c.y), light);
    }
  }
  // A board session's frames carry neither: their cells would cover the board where it reaches the
  // top and right edges of the view, whose corners tell the lens best (cam2's principal point from
  // the 48 poses rendered in-process: 1.18 px off with them, 0.43 px without), and a board session
  // is measured against the lens, not the clock.
  if (base.type() == CV_8UC1 && !board_) {
    cv::Mat view(height, width, CV_8UC1, data);
    draw_timecode(view, Timecode{true_ns, frame_id});
    draw_frame_stripe(view, frame_id);
  }
  const double noise = clock_.jitter_ns > 0 ? noise_(rng_) * clock_.jitter_ns : 0.0;
  // The image shows the scene at true_ns, the middle of its exposure; like a GigE Vision camera, the
  // stamp marks the exposure's start, half the exposure earlier (the truth keeps the image's instant).
  const std::int64_t device_ns =
      std::max<std::int64_t>(0, clock_.device_time(true_ns - exposure_ns / 2) + std::int64_t(noise));
  arv_buffer_set_timestamp(buffer, guint64(device_ns));
  truth_ << frame_id << ',' << true_ns << ',' << device_ns << ',' << width << ',' << height << '\n';
  ++emitted_;
  if (emitted_ % 32 == 0) truth_.flush();  // a killed run keeps nearly all of its truth
}

}  // namespace pvcap::sim
