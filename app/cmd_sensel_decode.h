#pragma once
// `pvcap sensel decode FILE`: prints what a Sensel wire dump (.json / .jsonl) holds
// (codec/sensel_capture_file.h decodes it); the process fails when any frame does.
#include <filesystem>

#include "codec/sensel_capture_file.h"

namespace pvcap {

// Prints the summary; returns the exit code (0 all frames decoded, 1 some failed).
int print_sensel_summary(const std::filesystem::path& path, const sensel::CaptureSummary& s);

}  // namespace pvcap
