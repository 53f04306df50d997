#include "app/rig_launcher.h"

#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "sim/sim_config.h"
#include "sim/sim_process.h"
#include "sim/sim_rig.h"

namespace pvcap {

namespace {
// A simulated rig's devices take a moment to come up after the simulator starts.
constexpr double kSimulatedDeviceWaitS = 10.0;

bool under_umockdev_preload() {
  const char* preload = std::getenv("LD_PRELOAD");
  return preload && std::string(preload).find("libumockdev-preload") != std::string::npos;
}

// Where the simulator serves its Sensel: a pseudo-terminal (truth_dir/sensel.tty) or, with
// `sim: {sensel: {transport: usb}}`, umockdev's emulated USB bus (truth_dir/sensel.usb, its testbed).
// The bus is this process's to see only under umockdev's preload library, with UMOCKDEV_DIR naming
// the testbed; set here, before the recording opens anything under /dev or /sys.
Status resolve_simulated_sensel(SenselRigConfig& sensel, const std::filesystem::path& truth_dir) {
  const auto tty = truth_dir / "sensel.tty", usb = truth_dir / "sensel.usb";
  std::error_code ec;
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(kSimulatedDeviceWaitS);
  while (!std::filesystem::is_symlink(tty, ec) && !std::filesystem::is_symlink(usb, ec) &&
         std::chrono::steady_clock::now() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  if (!std::filesystem::is_symlink(usb, ec)) {  // the pty (or nothing yet: the recording says so)
    sensel.tty = tty.string();
    return {};
  }
  if (!under_umockdev_preload())
    return Error{
        "the simulated rig serves its Sensel on an emulated USB bus (sim: sensel: transport: usb), which this "
        "process sees only under umockdev's preload library: run pvcap as "
        "LD_PRELOAD=libumockdev-preload.so.0 pvcap ..., or set transport: pty"};
  const auto testbed = std::filesystem::read_symlink(usb, ec);
  if (ec) return Error{fmt::format("cannot read {}: {}", usb.string(), ec.message())};
  setenv("UMOCKDEV_DIR", testbed.c_str(), 1);
  sensel.tty.clear();
  sensel.usb_serial = "";  // the only Morph on the emulated bus
  return {};
}
}  // namespace

void run_under_rig_preload(const RigConfig& rig) {
  if (!rig.simulated || !rig.sensel || rig.sensel->tty != "sim") return;
  const auto sim = sim::load_sim_config(rig);
  if (!sim || sim->sensel.transport != "usb") return;
  if (under_umockdev_preload()) return;
  constexpr const char* kPreload = "libumockdev-preload.so.0";
  const char* now = std::getenv("LD_PRELOAD");
  const std::string preload = now ? now : "";
  std::ifstream in("/proc/self/cmdline", std::ios::binary);
  const std::string cmdline((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::vector<char*> argv;
  for (std::size_t at = 0; at < cmdline.size(); at = cmdline.find('\0', at) + 1)
    argv.push_back(const_cast<char*>(cmdline.c_str() + at));
  argv.push_back(nullptr);
  setenv("LD_PRELOAD", (preload.empty() ? std::string(kPreload) : preload + ":" + kPreload).c_str(), 1);
  execv("/proc/self/exe", argv.data());
  throw UserError(
      fmt::format("the simulated rig's Sensel is on an emulated USB bus, which needs umockdev's preload "
                  "library; starting again under it failed: {}",
                  std::strerror(errno)));
}

void prepare_rig_network(const RigConfig& rig) {
  if (!rig.simulated) return;
  if (Status s = sim::ensure_network(rig); !s.ok()) throw UserError(s.error().message);
}

LaunchedRig::~LaunchedRig() {
  stop_devices();
  if (!truth_tmp_.empty()) {
    std::error_code ec;
    std::filesystem::remove_all(truth_tmp_, ec);
  }
}

bool LaunchedRig::steer(const sim::HandCommand& command) { return sim_ && sim_->steer(command); }

void LaunchedRig::stop_devices() { sim_.reset(); }

void LaunchedRig::file_truth(const std::filesystem::path& session_dir) {
  stop_devices();
  if (truth_tmp_.empty() || session_dir.empty()) return;
  std::error_code ec;
  std::filesystem::rename(truth_tmp_, session_dir / "sim-truth", ec);
  if (ec) {
    spdlog::warn("simulator ground truth stays in {}: {}", truth_tmp_.string(), ec.message());
    return;
  }
  truth_tmp_.clear();
}

Result<std::unique_ptr<LaunchedRig>> launch_rig(const RigConfig& rig, const LaunchOptions& options) {
  std::unique_ptr<LaunchedRig> r(new LaunchedRig());
  r->rig = rig;
  if (!rig.simulated) return r;
  // The simulator writes its ground truth beside the sessions while it runs (the same disk, so it can
  // be moved into the session folder at the end); its Sensel's pty is linked there as sensel.tty.
  r->truth_tmp_ = options.scratch_root / fmt::format(".sim-truth-{}", getpid());
  std::error_code ec;
  std::filesystem::create_directories(r->truth_tmp_, ec);
  if (ec) return Error{fmt::format("cannot create {}: {}", r->truth_tmp_.string(), ec.message())};
  auto started = sim::SimProcess::start(options.self_exe, rig.source, r->truth_tmp_, options.steerable, options.board);
  if (!started) return started.error();
  r->sim_ = std::move(started.value());
  r->device_wait_s = kSimulatedDeviceWaitS;
  if (r->rig.sensel && r->rig.sensel->tty == "sim") {
    if (Status s = resolve_simulated_sensel(*r->rig.sensel, r->truth_tmp_); !s.ok()) return s.error();
    r->sensel_ports_dir = r->truth_tmp_;
  }
  return r;
}

}  // namespace pvcap
