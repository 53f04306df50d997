#pragma once
// Running a helper program and reading what it prints (Slurm's commands, linuxptp's pmc): spawned
// with posix_spawnp (no fork of a process that holds capture threads), its standard output and error
// read together, and, given a time limit, killed when it has not ended by then, so that a helper
// that hangs costs its caller the limit and no more.
#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include "core/result.h"

namespace pvcap {

struct ProgramOutput {
  int exit_code = -1;  // -1: it did not exit by itself (a signal, or killed at the time limit)
  bool timed_out = false;
  std::string text;  // its standard output and error, interleaved as written
};

// Runs args[0] (found on PATH) with args[1...]. An Error only when it cannot be started at all
// (not installed, not executable); a program that fails or times out is an output with its code.
Result<ProgramOutput> run_program(const std::vector<std::string>& args,
                                  std::optional<std::chrono::milliseconds> time_limit = std::nullopt);

}  // namespace pvcap
