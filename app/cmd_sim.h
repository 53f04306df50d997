#pragma once
// `pvcap sim`: serves a simulated rig (GigE Vision cameras over loopback, the Sensel emulator)
// until `stop` is set or `duration` passes; with `hand_commands`, the simulated hand follows the
// commands read from stdin (what a recording with --auto sends); with `board`, the cameras see the
// calibration board moving through its poses (what a recording with --board starts); `faults`' sim.*
// entries break the simulated lamps.
#include <atomic>
#include <filesystem>
#include <optional>

#include "core/fault_injection.h"
#include "core/rig_config.h"

namespace pvcap {

int cmd_sim(const RigConfig& rig, const std::filesystem::path& truth, std::optional<double> duration,
            bool hand_commands, bool board, const FaultPlan& faults, std::atomic<bool>& stop);

}  // namespace pvcap
