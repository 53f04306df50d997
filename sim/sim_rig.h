#pragma once
// The simulated camera rig: one SimCamera per camera of a rig config that has a
// `sim:` section, each on its own 127.0.0.x address, with the clocks and faults
// the config gives. Writes the ground truth of the run into `truth_dir`:
// rig.json (clocks, homographies, pad geometry) and <camera>_frames.csv. With a
// `sensel: {tty: sim}` it also serves an emulated Sensel Morph on a pseudo-terminal,
// linked as truth_dir/sensel.tty, or (`sim: {sensel: {transport: usb}}`) on umockdev's
// emulated USB bus, its testbed linked as truth_dir/sensel.usb; it logs sensel_frames.csv. With `sim: {replay:
// SESSION}` the devices re-serve a recorded session instead (sim/session_replay.h).
#include <atomic>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/result.h"
#include "core/rig_config.h"
#include "sim/hand.h"
#include "sim/lights.h"
#include "sim/replay_camera.h"
#include "sim/sensel_emulator.h"
#include "sim/sensel_pty.h"
#include "sim/sensel_usb_device.h"
#include "sim/session_replay.h"
#include "sim/sim_camera.h"
#include "sim/sim_config.h"

namespace pvcap::sim {

class SimRig {
 public:
  // `board`: a calibration board session (the board moves through its poses; no hand).
  // `light_off`, `light_lag_s`: the lamps' faults (SimConfig's), which the rig file does not hold.
  static Result<std::unique_ptr<SimRig>> create(const RigConfig& rig, const std::filesystem::path& truth_dir,
                                                bool board = false, const std::string& light_off = "",
                                                double light_lag_s = 0);
  ~SimRig();

  // Serves until `stop` becomes true, removing cameras whose stop_after_s has passed and
  // bringing them back (power-cycled) at return_after_s.
  void run(const std::atomic<bool>& stop);
  std::size_t camera_count() const { return cameras_.size() + replay_cameras_.size(); }
  // Steers the simulated hand (protocol --auto); logged to truth_dir/hand.csv.
  void steer(const HandCommand& c);

 private:
  SimRig() = default;
  RigConfig rig_;
  SimConfig sim_;  // the rig's sim: section
  std::filesystem::path truth_dir_;
  std::int64_t t0_ns_ = 0;
  std::vector<int> returned_;  // per camera, how many of its outages have ended
  std::shared_ptr<Hand> hand_;
  std::shared_ptr<SimLights> lights_;  // the rig's lamps, shared by every camera that shows them
  std::mutex hand_truth_mu_;
  std::ofstream hand_truth_;
  std::ofstream sensel_truth_;
  std::unique_ptr<SenselEmulator> sensel_;
  std::unique_ptr<SenselPty> sensel_pty_;
  std::filesystem::path sensel_tty_link_;  // where sensel_pty_ is published (truth_dir/<name>)
  std::unique_ptr<SenselUsbDevice> sensel_usb_;
  bool sensel_unplugged_ = false, sensel_replugged_ = false;
  void replug_sensel();
  Status serve_sensel(SenselLink link, const std::string& name = "sensel.tty");
  nlohmann::json sensel_link() const;
  std::vector<std::unique_ptr<SimCamera>> cameras_;
  // A replayed session (`sim: {replay: SESSION}`) instead of the scene.
  std::shared_ptr<SessionReplay> replay_;
  std::vector<std::unique_ptr<ReplayCamera>> replay_cameras_;

  static Result<std::unique_ptr<SimRig>> create_replay(const RigConfig& rig, const SimConfig& sim,
                                                       const std::filesystem::path& truth_dir);
};

// The camera addresses of a simulated rig (for the network namespace).
std::vector<std::string> sim_addresses(const RigConfig& rig);

// A simulated rig's cameras need their 127.0.0.x addresses: unless this process already sees them
// (e.g. started by a test inside a namespace), enters a private network namespace that has them
// (sim/netns.h). Call before any thread starts.
Status ensure_network(const RigConfig& rig);

}  // namespace pvcap::sim
