#pragma once
// The end-of-session report the operator reads, built from what the store holds
// (not from a recorder's counters), so it says what a reader of the session will
// find, and an offline `pvcap` command can make the same report for any session.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/result.h"

namespace pvcap::report {

// `recorded_s`: how long the devices streamed, when known (otherwise the session's span).
Result<std::string> session_text(const std::filesystem::path& session_dir,
                                 std::optional<double> recorded_s = std::nullopt);

// What a session's end shows: the report above with the recorder's `notes`, and for a protocol session
// its takes (report.txt holds every take; the terminal, their totals). A part that cannot be read is
// said in the text and in `errors` (the command then ends in exit 1; the recorded data stays).
struct ClosingReport {
  std::string file;      // report.txt
  std::string terminal;  // what the operator's terminal shows
  std::vector<std::string> errors;
};
ClosingReport closing_report(const std::filesystem::path& session_dir, std::optional<double> recorded_s,
                             const std::vector<std::string>& notes, bool protocol);

}  // namespace pvcap::report
