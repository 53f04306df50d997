#pragma once
// A rig made ready to record. A real rig is recorded as its file says. A simulated rig (a rig file
// with a `sim:` section) gets its simulator here, as a child process (`pvcap sim`) in this
// process's private network namespace, like a separate box on the wire: its `sensel: {tty: sim}`
// resolved to the simulator's pseudo-terminal (or its emulated USB bus), the time its devices take to come up, the
// steering pipe of its hand (protocol --auto), and its ground truth filed in the session folder once the recording is
// done. app/ is the one place that starts the simulator; below it, a recording sees only what a real rig speaks (GigE
// Vision, the Sensel's wire protocol).
//
//   prepare_rig_network(rig);                   // before any thread starts (a simulated rig: netns)
//   auto launched = launch_rig(rig, options);   // the simulator serving, the rig resolved
//   ... record launched->rig with launched->device_wait_s ...
//   launched->stop_devices();                   // when the recording's devices have stopped
//   launched->file_truth(session_dir);          // sim-truth/ into the session folder
#include <filesystem>
#include <memory>

#include "core/result.h"
#include "core/rig_config.h"
#include "sim/hand.h"

namespace pvcap::sim {
class SimProcess;
}

namespace pvcap {

// A simulated rig whose Sensel is on umockdev's emulated USB bus (`sim: {sensel: {transport: usb}}`)
// is seen only by a process under umockdev's preload library: without it, this process starts itself
// again under it (same pid, same arguments; the library is loaded only at a program's start). Call
// before any socket is bound; a real rig, or a simulated one on a pseudo-terminal: nothing.
void run_under_rig_preload(const RigConfig& rig);

// A simulated rig's cameras need their 127.0.0.x addresses: enters a private network namespace that
// has them (unless this process already sees them). Call before any thread starts; a real rig: nothing.
void prepare_rig_network(const RigConfig& rig);

struct LaunchOptions {
  std::filesystem::path self_exe;      // the pvcap binary, to start `pvcap sim`
  std::filesystem::path scratch_root;  // where the simulator's truth waits (the sessions folder: same disk)
  bool steerable = false;              // the simulated hand takes commands (protocol --auto)
  bool board = false;                  // a calibration board session: the simulator moves its board
};

class LaunchedRig {
 public:
  ~LaunchedRig();  // stops the simulator; truth not filed is removed
  LaunchedRig(const LaunchedRig&) = delete;
  LaunchedRig& operator=(const LaunchedRig&) = delete;

  RigConfig rig;                                    // resolved: a simulated Sensel's tty is the simulator's pty
  double device_wait_s = 0;                         // how long opening the devices may keep trying
  std::filesystem::path sensel_ports_dir = "/dev";  // where a Morph back under another name is looked for

  bool simulated() const { return bool(sim_); }
  // Where the simulated hand goes next (a steerable simulator); false when there is none or it is gone.
  bool steer(const sim::HandCommand& command);
  // Stops the simulator (its devices go away); its truth files are complete afterwards.
  void stop_devices();
  // Moves the simulator's ground truth into `session_dir`/sim-truth (stopping it first).
  void file_truth(const std::filesystem::path& session_dir);

 private:
  friend Result<std::unique_ptr<LaunchedRig>> launch_rig(const RigConfig& rig, const LaunchOptions& options);
  LaunchedRig() = default;
  std::unique_ptr<sim::SimProcess> sim_;
  std::filesystem::path truth_tmp_;
};

// A real rig: as it is. A simulated one: its simulator started and the rig resolved.
Result<std::unique_ptr<LaunchedRig>> launch_rig(const RigConfig& rig, const LaunchOptions& options);

}  // namespace pvcap
