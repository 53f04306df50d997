// `pvcap sim`: serves a simulated rig (GigE Vision cameras over loopback, the Sensel emulator) until
// stopped or its duration passes; with `--hand-commands`, the simulated hand follows the commands read
// from stdin (what a recording with --auto sends); with `--board`, the cameras see the calibration
// board moving through its poses; PVCAP_FAULTS' sim.* entries break the simulated lamps.
#include "app/command.h"
#include "app/rig_launcher.h"

#include <sys/prctl.h>
#include <unistd.h>

#include <csignal>
#include <iostream>
#include <thread>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "core/fault_injection.h"
#include "sim/hand.h"
#include "sim/sim_rig.h"

namespace pvcap {

namespace {

int cmd_sim(const RigConfig& rig, const std::filesystem::path& truth, std::optional<double> duration,
            bool hand_commands, bool board, const FaultPlan& faults, std::atomic<bool>& stop) {
  // Started by a recording: end with it, even when it is killed (no orphaned simulator holding the rig).
  if (getppid() != 1) {
    const pid_t parent = getppid();
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (getppid() != parent) return 0;  // the parent died before the request took
  }
  auto made = sim::SimRig::create(rig, truth, board, faults.sim_light_off, faults.sim_light_lag_s);
  if (!made) throw UserError(made.error().message);
  fmt::print(stderr,
             "pvcap sim: serving {} cameras; pid {} (inspect with: nsenter --net=/proc/{}/ns/net "
             "arv-tool-0.8)\n",
             made.value()->camera_count(), getpid(), getpid());
  std::thread timer;
  if (duration)
    timer = std::thread([&] {
      const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(*duration);
      while (!stop.load() && std::chrono::steady_clock::now() < end)
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      stop.store(true);
    });
  // Steered by a recording (protocol --auto): one hand command per line on stdin. Detached: it
  // may sit in a read until the process exits.
  if (hand_commands)
    std::thread([rig = made.value().get()] {
      std::string line;
      while (std::getline(std::cin, line)) {
        if (auto c = sim::HandCommand::parse(line))
          rig->steer(*c);
        else
          spdlog::warn("sim: not a hand command: {}", line);
      }
    }).detach();
  made.value()->run(stop);
  if (timer.joinable()) timer.join();
  return 0;
}

}  // namespace

Registered add_sim_command(CLI::App& app, AppContext& ctx) {
  struct Args {
    std::string rig, truth = "sim-truth";
    std::optional<double> duration;
    bool hand_commands = false, board = false;
  };
  auto a = std::make_shared<Args>();
  auto* s = app.add_subcommand("sim", "serve a simulated rig (GigE Vision cameras over loopback)");
  s->add_option("--rig", a->rig, "rig file with a sim: section")->required()->check(CLI::ExistingFile);
  s->add_option("--truth", a->truth, "folder for the ground truth of the run")->capture_default_str();
  s->add_option("--duration", a->duration, "stop after this many seconds")->check(CLI::PositiveNumber);
  s->add_flag("--hand-commands", a->hand_commands, "steer the simulated hand by commands on stdin (one a line)");
  s->add_flag("--board", a->board, "the cameras see the calibration board moving through its poses");
  return {s, [a, &ctx] {
            const auto rig = load_rig_config(a->rig);
            if (!rig.simulated) throw UserError(fmt::format("{}: has no sim: section", a->rig));
            prepare_rig_network(rig);
            return cmd_sim(rig, a->truth, a->duration, a->hand_commands, a->board, ctx.faults, ctx.stop);
          }};
}

}  // namespace pvcap
