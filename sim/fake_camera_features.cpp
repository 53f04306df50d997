#include "sim/fake_camera_features.h"

#include <pthread.h>
#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "core/time.h"

namespace pvcap::sim {

void install_fake_camera_genicam() {
  static std::once_flag once;
  std::call_once(once, [] {
    arv::GPtr<ArvFakeCamera> probe(arv_fake_camera_new("PVSIM-XML"));
    size_t size = 0;
    const char* xml = probe ? arv_fake_camera_get_genicam_xml(probe.get(), &size) : nullptr;
    if (!xml) return;
    std::string text(xml, size);
    while (!text.empty() && text.back() == '\0') text.pop_back();
    const std::string features = fmt::format(
        R"(<Command Name="TimestampControlLatch" NameSpace="Standard">
<ToolTip>Latches the device clock into TimestampLatchValue</ToolTip>
<pValue>PvcapTimestampLatchCommand</pValue><CommandValue>1</CommandValue></Command>
<IntReg Name="PvcapTimestampLatchCommand" NameSpace="Custom"><Address>{:#x}</Address><Length>4</Length>
<AccessMode>RW</AccessMode><pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>BigEndian</Endianess></IntReg>
<IntReg Name="TimestampLatchValue" NameSpace="Standard"><Address>{:#x}</Address><Length>8</Length>
<AccessMode>RO</AccessMode><pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>BigEndian</Endianess></IntReg>
<IntReg Name="PvcapTriggerSourceRegister" NameSpace="Custom"><Address>{:#x}</Address><Length>4</Length>
<AccessMode>RW</AccessMode><pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>BigEndian</Endianess></IntReg>
)",
        kLatchCommandRegister, kLatchValueRegister, kTriggerSourceRegister);
    const auto end = text.rfind("</RegisterDescription>");
    if (end == std::string::npos) return;
    text.insert(end, features);
    // TriggerSource reads and writes our register; the engine's own stays at Software (set per camera).
    const auto source = text.find("<Enumeration Name=\"TriggerSource\"");
    const std::string engine_register = "<pValue>TriggerSourceRegister</pValue>";
    const auto value = source == std::string::npos ? std::string::npos : text.find(engine_register, source);
    if (value != std::string::npos)
      text.replace(value, engine_register.size(), "<pValue>PvcapTriggerSourceRegister</pValue>");
    // Named by its content, so every simulator process shares one file instead of leaving one
    // each; written aside and renamed into place, so a concurrent reader never sees half of it.
    const auto dir = std::filesystem::temp_directory_path();
    const auto path = dir / fmt::format("pvcap-fake-camera-{:016x}.xml", std::hash<std::string>{}(text));
    if (!std::filesystem::exists(path)) {
      const auto aside = dir / fmt::format("pvcap-fake-camera-{}.xml.tmp", getpid());
      std::ofstream(aside) << text;
      std::error_code ec;
      std::filesystem::rename(aside, path, ec);
      if (ec) std::filesystem::remove(aside, ec);
    }
    arv_set_fake_camera_genicam_filename(path.c_str());
  });
}

namespace {
// One thread serves the latch and trigger line of every simulated camera in the process (a
// thread per camera polling this often would take a good part of a core from the simulators).
class FeatureService {
 public:
  static FeatureService& get() {
    static FeatureService service;
    return service;
  }
  void add(const void* owner, ArvFakeCamera* fake, DeviceClock clock, TriggerLine line) {
    // The engine triggers on a pending software trigger; which source the host chose is ours.
    arv_fake_camera_write_register(fake, kEngineTriggerSource, kSoftware);
    std::lock_guard lock(mu_);
    cameras_.push_back({owner, fake, std::move(clock), std::move(line), INT64_MIN});
    if (!thread_.joinable()) thread_ = std::thread([this] { run(); });
  }
  void remove(const void* owner) {
    std::lock_guard lock(mu_);
    cameras_.erase(std::remove_if(cameras_.begin(), cameras_.end(), [&](const Camera& c) { return c.owner == owner; }),
                   cameras_.end());
  }
  ~FeatureService() {
    running_.store(false);
    if (thread_.joinable()) thread_.join();
  }

 private:
  // The fake engine's registers (arvfakecamera.h).
  static constexpr std::uint32_t kEngineTriggerMode = 0x300, kEngineTriggerSource = 0x304,
                                 kEngineTriggerSoftware = 0x30c, kSoftware = 1;
  struct Camera {
    const void* owner;
    ArvFakeCamera* fake;
    DeviceClock clock;
    TriggerLine line;
    std::int64_t last_pulse;  // the line's last pulse that reached this camera (its index)
  };
  // When the host has set the command register, the device clock's value goes into the value
  // register and the command clears.
  static void serve_latch(const Camera& c) {
    guint32 command = 0;
    if (!arv_fake_camera_read_register(c.fake, kLatchCommandRegister, &command) || command == 0) return;
    const auto device = std::uint64_t(std::max<std::int64_t>(0, c.clock(host_now().ns)));
    arv_fake_camera_write_register(c.fake, kLatchValueRegister, guint32(device >> 32));
    arv_fake_camera_write_register(c.fake, kLatchValueRegister + 4, guint32(device & 0xFFFFFFFFu));
    arv_fake_camera_write_register(c.fake, kLatchCommandRegister, 0);
  }
  // At each new pulse of the line, a camera triggered by it (TriggerMode On, source Line0) is
  // triggered as the engine understands it (a trigger pending until it acquires).
  static void serve_line(Camera& c, std::int64_t now_ns) {
    if (!c.line) return;
    guint32 mode = 0, source = 0;
    if (!arv_fake_camera_read_register(c.fake, kEngineTriggerMode, &mode) || mode != 1) return;
    if (!arv_fake_camera_read_register(c.fake, kTriggerSourceRegister, &source) || source == kSoftware) return;
    const std::int64_t pulse = c.line(now_ns);
    if (pulse <= c.last_pulse) return;
    c.last_pulse = pulse;
    arv_fake_camera_write_register(c.fake, kEngineTriggerSoftware, 1);
  }
  void run() {
    // A camera's latch and trigger input are its hardware's; here a thread serves them every 200 us,
    // 3,000-5,000 wake-ups a second. In the fair scheduler, on saturated cores, the kernel worker
    // that carries a pseudo-terminal's bytes (the simulated Morph's) was traced waiting 107 ms behind
    // it and a busy loop (4 of 24 sessions lost pressure samples so, 0 of 24 with a 1 ms poll;
    // docs/testing.md, "How the suite is scheduled"). At a real-time priority, where allowed, it
    // leaves the fair scheduler to the threads that share it.
    {
      sched_param rt{};
      rt.sched_priority = 5;
      (void)pthread_setschedparam(pthread_self(), SCHED_FIFO, &rt);
    }
    while (running_.load()) {
      std::this_thread::sleep_for(std::chrono::microseconds(200));
      const std::int64_t now = host_now().ns;
      std::lock_guard lock(mu_);
      for (Camera& c : cameras_) {
        serve_latch(c);
        serve_line(c, now);
      }
    }
  }
  std::mutex mu_;
  std::vector<Camera> cameras_;
  std::atomic<bool> running_{true};
  std::thread thread_;
};
}  // namespace

TriggerLine periodic_line(double hz) {
  return [hz](std::int64_t host_ns) { return std::int64_t(double(host_ns) * hz / 1e9); };
}

void serve_features(const void* owner, ArvFakeCamera* fake, DeviceClock clock, TriggerLine line) {
  FeatureService::get().add(owner, fake, std::move(clock), std::move(line));
}
void stop_serving(const void* owner) { FeatureService::get().remove(owner); }

}  // namespace pvcap::sim
