#pragma once
// The end-of-session report the operator reads, built from what the store holds
// (not from a recorder's counters), so it says what a reader of the session will
// find, and an offline `pvcap` command can make the same report for any session.
#include <filesystem>
#include <optional>
#include <string>

#include "core/result.h"

namespace pvcap::report {

// `recorded_s`: how long the devices streamed, when known (otherwise the session's span).
Result<std::string> session_text(const std::filesystem::path& session_dir,
                                 std::optional<double> recorded_s = std::nullopt);

}  // namespace pvcap::report
