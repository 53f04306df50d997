#pragma once
// `pvcap sim`: serves a simulated rig (GigE Vision cameras over loopback, the Sensel emulator)
// until `stop` is set or `duration` passes; with `hand_commands`, the simulated hand follows the
// commands read from stdin (what a recording with --auto sends).
#include <atomic>
#include <filesystem>
#include <optional>

#include "core/rig_config.h"

namespace pvcap {

int cmd_sim(const RigConfig& rig, const std::filesystem::path& truth, std::optional<double> duration, bool hand_commands,
            std::atomic<bool>& stop);

}  // namespace pvcap
