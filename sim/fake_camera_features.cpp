#include "sim/fake_camera_latch.h"

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

void install_latch_genicam() {
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
)",
        kLatchCommandRegister, kLatchValueRegister);
    const auto end = text.rfind("</RegisterDescription>");
    if (end == std::string::npos) return;
    text.insert(end, features);
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
// One thread serves the latch of every simulated camera in the process (a thread per camera
// polling this often would take a good part of a core from the simulators).
class LatchService {
 public:
  static LatchService& get() {
    static LatchService service;
    return service;
  }
  void add(const void* owner, ArvFakeCamera* fake, DeviceClock clock) {
    std::lock_guard lock(mu_);
    latches_.push_back({owner, fake, std::move(clock)});
    if (!thread_.joinable()) thread_ = std::thread([this] { run(); });
  }
  void remove(const void* owner) {
    std::lock_guard lock(mu_);
    latches_.erase(std::remove_if(latches_.begin(), latches_.end(), [&](const Latch& l) { return l.owner == owner; }),
                   latches_.end());
  }
  ~LatchService() {
    running_.store(false);
    if (thread_.joinable()) thread_.join();
  }

 private:
  struct Latch {
    const void* owner;
    ArvFakeCamera* fake;
    DeviceClock clock;
  };
  // When the host has set the command register, the device clock's value goes into the value
  // register and the command clears.
  static void serve(const Latch& l) {
    guint32 command = 0;
    if (!arv_fake_camera_read_register(l.fake, kLatchCommandRegister, &command) || command == 0) return;
    const auto device = std::uint64_t(std::max<std::int64_t>(0, l.clock(host_now().ns)));
    arv_fake_camera_write_register(l.fake, kLatchValueRegister, guint32(device >> 32));
    arv_fake_camera_write_register(l.fake, kLatchValueRegister + 4, guint32(device & 0xFFFFFFFFu));
    arv_fake_camera_write_register(l.fake, kLatchCommandRegister, 0);
  }
  void run() {
    while (running_.load()) {
      std::this_thread::sleep_for(std::chrono::microseconds(200));
      std::lock_guard lock(mu_);
      for (const Latch& l : latches_) serve(l);
    }
  }
  std::mutex mu_;
  std::vector<Latch> latches_;
  std::atomic<bool> running_{true};
  std::thread thread_;
};
}  // namespace

void add_latch(const void* owner, ArvFakeCamera* fake, DeviceClock clock) {
  LatchService::get().add(owner, fake, std::move(clock));
}
void remove_latch(const void* owner) { LatchService::get().remove(owner); }

}  // namespace pvcap::sim
