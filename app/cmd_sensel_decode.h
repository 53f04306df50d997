#pragma once
// `pvcap sensel decode FILE`: decodes a Sensel wire dump (.json / .jsonl) and
// summarises it; the process fails when any frame does.
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>

#include "capture/sensel_pressure_codec.h"
#include "core/result.h"

namespace pvcap {

struct SenselDecodeSummary {
  std::size_t frames = 0, decoded = 0;
  std::map<std::string, std::size_t> rejected;  // reason -> count
  std::string first_rejection;                  // "line N: reason", for the message
  sensel::Grid grid;
  std::uint64_t counter_gaps = 0;               // frames missing by the rolling counter
  double span_s = 0;                            // device timestamp span (unwrapped)
  double peak_cell_g = 0, peak_cell_kpa = 0;    // heaviest native cell of any frame
  double peak_total_g = 0;                      // largest per-frame sum
};

Result<SenselDecodeSummary> decode_sensel_capture(const std::filesystem::path& path);
// Prints the summary; returns the exit code (0 all frames decoded, 1 some failed).
int print_sensel_summary(const std::filesystem::path& path, const SenselDecodeSummary& s);

}  // namespace pvcap
