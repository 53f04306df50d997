#pragma once
// Wire dumps of a Sensel Morph in the two formats of Sensel-Morph-Liberation's
// recorder (see ../shared/data/sensel-captures/README.md): one .json object, or
// .jsonl with a header line and one line per frame. Loading checks the file's
// shape; decoding the frames is the codec's job.
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "codec/sensel_pressure_codec.h"
#include "core/result.h"

namespace pvcap::sensel {

struct CapturedFrame {
  std::size_t line = 0;  // .jsonl line (1-based) or .json frame index
  std::vector<std::uint8_t> payload;
  int checksum = -1;  // as recorded (-1: none recorded)
};

struct CaptureFile {
  std::filesystem::path path;
  std::vector<std::uint8_t> metadata;  // register 0x1C's 6 bytes
  std::vector<CapturedFrame> frames;
};

Result<CaptureFile> load_capture_file(const std::filesystem::path& path);

// What a capture file holds, every frame decoded (what `pvcap sensel decode` prints).
struct CaptureSummary {
  std::size_t frames = 0, decoded = 0;
  std::map<std::string, std::size_t> rejected;  // reason -> count
  std::string first_rejection;                  // "frame at N: reason", for the message
  Grid grid;
  std::uint64_t counter_gaps = 0;             // frames missing by the rolling counter
  double span_s = 0;                          // device timestamp span (unwrapped)
  double peak_cell_g = 0, peak_cell_kpa = 0;  // heaviest native cell of any frame
  double peak_total_g = 0;                    // largest per-frame sum
};
Result<CaptureSummary> summarise_capture_file(const std::filesystem::path& path);

}  // namespace pvcap::sensel
