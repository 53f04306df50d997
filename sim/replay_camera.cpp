#include "sim/replay_camera.h"

#include <pthread.h>
#include <sched.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "core/time.h"
#include "sim/fake_camera_features.h"
#include "sim/scene.h"
#include "storage/index/session_reader.h"

namespace pvcap::sim {

namespace {
constexpr std::size_t kReadAhead = 12;    // stored mosaics decoded ahead of their frames
constexpr int kEnginePriority = 10;       // SCHED_FIFO, around each frame (the kicker's is 11)
constexpr int kSendPriority = 9;          // SCHED_FIFO, while the engine sends a frame's packets
constexpr std::int64_t kSpinNs = 80'000;  // the end of the wait for a frame's instant, spun

// Aravis' fake camera sends its next frame at the next multiple of its frame period (CLOCK_REALTIME,
// microseconds) after it has sent this one. The period returned puts that multiple in
// [target_us - window_us, target_us]: the engine wakes just before the frame is due.
std::uint32_t period_waking_at(std::int64_t now_us, std::int64_t target_us, std::int64_t window_us) {
  const std::int64_t d = target_us - now_us;
  if (d <= window_us) return 1;  // due now: wake at once
  for (std::int64_t p = d - window_us; p <= 8 * d + 100'000 && p < INT32_MAX; ++p) {
    const std::int64_t next = now_us + p - now_us % p;
    if (next >= target_us - window_us && next <= target_us) return std::uint32_t(p);
  }
  return 1000;  // none found (never seen): wake every millisecond until it is due
}
}  // namespace

Result<std::unique_ptr<ReplayCamera>> ReplayCamera::create(const CameraConfig& camera,
                                                           std::shared_ptr<SessionReplay> replay,
                                                           const std::filesystem::path& truth_dir) {
  if (camera.address.empty())
    return Error{fmt::format("{}: a replayed camera needs an 'address' (127.0.0.x)", camera.name)};
  auto index = replay->camera_index(camera.name);
  if (!index) return index.error();
  std::unique_ptr<ReplayCamera> self(new ReplayCamera());
  self->name_ = camera.name;
  self->pixel_format_ = camera.pixel_format;
  self->replay_ = std::move(replay);
  self->index_ = index.value();
  const auto log_path = truth_dir / (camera.name + "_replay.csv");
  self->log_.open(log_path);
  if (!self->log_) return Error{fmt::format("cannot write {}", log_path.string())};
  // entered_ns: when the engine called the fill; image_ns: when its stored mosaic was at hand
  // (what a late frame was waiting for).
  self->log_ << "frame_id,device_ns,due_ns,sent_ns,entered_ns,image_ns\n";
  const std::string serial = camera.serial.empty() ? camera.name : camera.serial;
  const std::string genicam = fake_camera_genicam(NodeMapNaming::Aravis);
  self->fake_.reset(
      arv_gv_fake_camera_new_full(camera.address.c_str(), serial.c_str(), genicam.empty() ? nullptr : genicam.c_str()));
  if (!self->fake_ || !arv_gv_fake_camera_is_running(self->fake_.get()))
    return Error{
        fmt::format("{}: the fake camera could not listen on {} (the simulated rig runs in its own network "
                    "namespace)",
                    camera.name, camera.address)};
  ReplayCamera* raw = self.get();
  raw->reader_ = std::thread([raw] { raw->read_ahead(); });
  // A frame not begun 0.15 ms after it is due has met the engine's stall (sim/engine_kicker.h): it
  // begins 0-0.15 ms before. And the engine's thread holds its real-time priority only around its
  // frames (the same file says why).
  auto next_due = [raw] {
    const auto& frames = raw->replay_->camera_frames(raw->index_);
    const std::size_t n = raw->next_.load();
    if (!raw->streaming_.load() || n >= frames.size()) return INT64_MAX;
    return raw->replay_->due_ns(frames[n].t_ns);
  };
  raw->kicker_ = std::make_unique<EngineKicker>(
      camera.address,
      [next_due] {
        const std::int64_t due = next_due();
        return due == INT64_MAX ? due : due + 150'000;
      },
      EngineKicker::LentPriority{next_due, [raw] { return raw->engine_thread_.load(); }, kEnginePriority});
  ArvFakeCamera* fake = arv_gv_fake_camera_get_fake_camera(raw->fake_.get());
  arv_fake_camera_set_fill_pattern(fake, &ReplayCamera::fill, raw);
  // Triggered (a session recorded with hardware triggers), the engine looks for a trigger once per
  // 1/trigger_frequency: paced like the free-running engine's frame period (plan_next_tick), it wakes
  // just before each frame is due, after the line's pulse (10 ms ahead); the fill waits the rest.
  arv_fake_camera_set_trigger_frequency(fake, 100.0);
  // A latch read before any frame (the recorder probes as acquisition starts) fixes the replay's shift
  // as a first frame would: a clock read before the shift is fixed would not be the one its frames
  // carry.
  serve_features(
      raw, fake,
      [raw](std::int64_t host_ns) {
        (void)raw->replay_->start(host_ns);
        return raw->replay_->camera_device_time(raw->index_, host_ns);
      },
      [raw](std::int64_t host_ns) { return raw->line_pulse(host_ns); });
  spdlog::info("replay: {} re-serves {} recorded frames on {}", camera.name,
               raw->replay_->camera_frames(raw->index_).size(), camera.address);
  return self;
}

ReplayCamera::~ReplayCamera() {
  stop_serving(this);
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  changed_.notify_all();
  kicker_.reset();
  fake_.reset();  // joins the engine's thread: no fill runs after this
  if (reader_.joinable()) reader_.join();
  log_.flush();
}

std::int64_t ReplayCamera::line_pulse(std::int64_t host_ns) const {
  // Well ahead of the engine's wake (0.2-0.5 ms before the frame is due): this runs on an ordinary
  // thread, which a busy machine may hold back by milliseconds, and a wake that finds no trigger
  // sleeps a whole period. Early is harmless: the trigger waits for the wake.
  constexpr std::int64_t kLeadNs = 10'000'000;
  if (!streaming_.load()) return 0;  // pending until the camera acquires: its first fill starts it
  // Pulse k + 1 once frame k (the next to send) is due, less the lead.
  const std::size_t next = next_.load();
  const auto& frames = replay_->camera_frames(index_);
  // (A frame not yet due gives no pulse: frames skipped at the start are not pulses either.)
  if (next >= frames.size() || replay_->due_ns(frames[next].t_ns) - kLeadNs > host_ns) return INT64_MIN;
  return std::int64_t(next) + 1;
}

void ReplayCamera::read_ahead() {
  auto reader = SessionReader::open(replay_->dir());
  std::optional<std::size_t> camera;
  if (reader) {
    for (std::size_t i = 0; i < reader.value()->cameras().size(); ++i)
      if (reader.value()->cameras()[i].name == name_) camera = i;
  } else {
    spdlog::warn("replay: {}: stored images cannot be read ({}); sending grey frames", name_, reader.error().message);
  }
  bool warned = false, said_colour = false;
  for (const auto& f : replay_->camera_frames(index_)) {
    if (f.sample < 0) continue;
    cv::Mat mosaic;
    if (reader && camera) {
      auto got = reader.value()->raw_image(std::size_t(f.sample), *camera);
      if (got) {
        mosaic = std::move(got.value());
      } else if (auto colour = reader.value()->image(std::size_t(f.sample), *camera); colour) {
        // A colour store holds no mosaic: its image is sampled back into the sensor's pattern.
        if (!colour.value().empty()) mosaic = to_sensor_format(colour.value(), pixel_format_);
        if (!said_colour)
          spdlog::warn(
              "replay: {}: the store keeps colour video, not the sensor's mosaics: its images are sent "
              "sampled back into {} (lossy video: close to what was captured, not bit for bit)",
              name_, pixel_format_);
        said_colour = true;
      } else if (!warned) {
        warned = true;
        spdlog::warn("replay: {}: sample {}: {} (frames without a stored image are sent grey)", name_, f.sample,
                     got.error().message);
      }
    }
    std::vector<cv::Mat> retired;
    {
      std::unique_lock lock(mu_);
      changed_.wait(lock, [&] { return stop_ || ready_.size() < kReadAhead; });
      if (stop_) return;
      ready_.emplace_back(f.sample, std::move(mosaic));
      retired.swap(retired_);
      changed_.notify_all();
    }
  }  // (what was retired is freed here, outside the lock)
}

cv::Mat ReplayCamera::stored_image(std::int64_t sample) {
  std::unique_lock lock(mu_);
  for (;;) {
    while (!ready_.empty() && ready_.front().first < sample) ready_.pop_front();  // frames skipped at the start
    if (!ready_.empty() && ready_.front().first == sample) {
      cv::Mat m = std::move(ready_.front().second);
      ready_.pop_front();
      changed_.notify_all();
      return m;
    }
    changed_.notify_all();
    // The read-ahead is behind (a busy machine): wait a little, then send what there is.
    if (!changed_.wait_for(lock, std::chrono::milliseconds(30), [&] { return stop_ || !ready_.empty(); }) || stop_)
      return {};
  }
}

void ReplayCamera::fill(ArvBuffer* buffer, void* self, guint32, guint32, ArvPixelFormat) {
  static_cast<ReplayCamera*>(self)->fill_buffer(buffer);
}

void ReplayCamera::fill_buffer(ArvBuffer* buffer) {
  const auto& frames = replay_->camera_frames(index_);
  const std::int64_t now = host_now().ns;
  const bool first = !streaming_;
  if (first) {
    // Acquisition has started: the first device to stream fixes the replay's shift. Frames due
    // before this camera started are not sent (the recorder was not listening yet).
    replay_->start(now);
    // The frames' timing is what is replayed: where allowed (root, or an rtprio limit), the engine's
    // thread wakes at a real-time priority, so a busy recorder beside it does not delay its frames.
    // From the next frame on, the kicker lends it only around each frame (sim/engine_kicker.h).
    sched_param rt{};
    rt.sched_priority = kEnginePriority;
    if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &rt) != 0)
      spdlog::debug("replay: {}: sending at normal priority (no permission for SCHED_FIFO)", name_);
    // Its poll then wakes when asked, not up to 50 us later (the default timer slack).
    prctl(PR_SET_TIMERSLACK, 1UL, 0, 0, 0);
    engine_thread_ = gettid();
    while (next_ < frames.size() && replay_->due_ns(frames[next_].t_ns) < now) ++next_;
  }
  ArvFakeCamera* fake = arv_gv_fake_camera_get_fake_camera(fake_.get());
  if (next_ >= frames.size()) {
    // Over (or the recorder restarted acquisition after the end): the engine sends this buffer
    // whatever happens; then it sleeps for good.
    arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_ACQUISITION_FRAME_PERIOD_US, 0xFFFFFFFFu);
    arv_buffer_set_frame_id(buffer, frames.empty() ? 1 : frames.back().frame_id);
    streaming_ = true;
    return;
  }
  const ReplayCameraFrame& f = frames[next_++];
  if (first) streaming_ = true;  // only now: the trigger line's next pulse is for the frame after this one
  const std::int64_t due = replay_->due_ns(f.t_ns);
  cv::Mat image = f.sample >= 0 ? stored_image(f.sample) : cv::Mat();
  const std::int64_t image_ns = host_now().ns;
  if (!image.empty()) {
    std::lock_guard lock(mu_);
    retired_.push_back(std::move(last_));
    last_ = image;
  } else {
    image = last_;
  }
  // The image is in the buffer before the frame's instant, as a camera's is at the end of its
  // exposure: what is left at the instant is nothing but the stamp. (Copied after it, two cameras
  // due at once on a trigger line left 0.3-0.6 ms late at p95, each waiting for the other's copy.)
  size_t size = 0;
  auto* data = static_cast<std::uint8_t*>(const_cast<void*>(arv_buffer_get_data(buffer, &size)));
  const std::size_t payload = arv_fake_camera_get_payload(fake);
  if (data) {
    if (!image.empty() && image.isContinuous())
      std::memcpy(data, image.data, std::min(payload, image.total() * image.elemSize()));
    else
      std::memset(data, 128, payload);
  }
  // The engine woke just before the frame is due: the rest is slept, but for the last moment
  // (a sleeping thread wakes 30-80 us late here), which is waited without giving up the core.
  if (due - host_now().ns > kSpinNs) {
    const std::int64_t until = due - kSpinNs;
    const timespec at{time_t(until / 1'000'000'000), long(until % 1'000'000'000)};
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &at, nullptr) == EINTR) {
    }
  }
  while (host_now().ns < due) {
  }
  arv_buffer_set_frame_id(buffer, f.frame_id);
  arv_buffer_set_timestamp(buffer, guint64(std::max<std::int64_t>(0, f.device_ns)));
  log_ << f.frame_id << ',' << f.device_ns << ',' << due << ',' << host_now().ns << ',' << now << ',' << image_ns
       << '\n';  // leaves now
  if (++logged_ % 32 == 0) log_.flush();
  plan_next_tick();
  // The engine sends the frame's packets after this returns: at a priority under the frames'
  // instants, so another camera whose frame falls due meanwhile leaves on time (on 2 cores, four
  // cameras due together would otherwise wait for each other's packets: ~0.45 ms per 640 x 480 frame).
  sched_param send{};
  send.sched_priority = kSendPriority;
  (void)pthread_setschedparam(pthread_self(), SCHED_FIFO, &send);
}

void ReplayCamera::plan_next_tick() {
  const auto& frames = replay_->camera_frames(index_);
  ArvFakeCamera* fake = arv_gv_fake_camera_get_fake_camera(fake_.get());
  if (next_ >= frames.size()) {  // that was the last frame: no more ticks
    arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_ACQUISITION_FRAME_PERIOD_US, 0xFFFFFFFFu);
    return;
  }
  // Wake 0-0.15 ms before the next frame is due; the fill waits the rest (the engine answers no
  // control packet while a fill waits, so the wait is kept short).
  const std::int64_t mono = host_now().ns;
  const std::int64_t real_us = g_get_real_time();
  const std::int64_t due_us = real_us + (replay_->due_ns(frames[next_].t_ns) - mono) / 1000;
  const std::uint32_t period_us = period_waking_at(real_us, due_us, 150);
  arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_ACQUISITION_FRAME_PERIOD_US, period_us);
  // The same wake when triggered (the engine truncates 1e6 / frequency to whole microseconds).
  arv_fake_camera_set_trigger_frequency(fake, 1e6 / (double(period_us) + 0.5));
}

}  // namespace pvcap::sim
