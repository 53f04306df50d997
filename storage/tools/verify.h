#pragma once
// Verifying a session folder (`pvcap verify`) the way a reader will use it.
// The index against the videos (every kept frame is in its video at its index, with
// its timestamp; no frame more, none less), every pressure frame decodes, every
// sample names frames that are in the videos, the schema is one this pvcap reads.
// Losses recorded during capture (drops, incomplete frames, encoder behind, samples
// without pressure, an unclean end) make it "lossy but readable", not failed. The videos are
// checked side by side (up to four at once); `progress` is called from those threads, one at a time.
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace pvcap {

struct VerifyReport {
  std::vector<std::string> facts;   // what was checked and found in order
  std::vector<std::string> losses;  // recorded losses: readable, but not everything is there
  std::vector<std::string> errors;  // the session (or a part of it) cannot be read as indexed
  double elapsed_s = 0;             // how long the check took
  double session_s = 0;             // how long the recording lasted (0: it did not end cleanly)
  // 0 clean, 3 lossy but readable, 1 failed.
  int exit_code() const { return !errors.empty() ? 1 : !losses.empty() ? 3 : 0; }
};

VerifyReport verify_session(const std::filesystem::path& dir,
                            const std::function<void(const std::string&)>& progress = nullptr);
std::string format_report(const std::filesystem::path& dir, const VerifyReport& report);

}  // namespace pvcap
