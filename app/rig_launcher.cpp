#include "app/rig_launcher.h"

#include <unistd.h>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "sim/sim_process.h"
#include "sim/sim_rig.h"

namespace pvcap {

namespace {
// A simulated rig's devices take a moment to come up after the simulator starts.
constexpr double kSimulatedDeviceWaitS = 10.0;
}  // namespace

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
    r->rig.sensel->tty = (r->truth_tmp_ / "sensel.tty").string();
    r->sensel_ports_dir = r->truth_tmp_;
  }
  return r;
}

}  // namespace pvcap
