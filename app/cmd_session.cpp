#include "app/cmd_session.h"

#include <fmt/format.h>

#include "app/cmd_report.h"

namespace pvcap {

int cmd_session(const RigConfig& rig, const protocol::SessionSetup& setup, const std::atomic<bool>& interrupt) {
  const auto outcome = protocol::run_session(rig, setup, interrupt);
  if (!outcome.recording.report.empty()) fmt::print("\n{}", outcome.recording.report);
  if (!outcome.takes_totals.empty()) fmt::print("\n{}", outcome.takes_totals);
  if (!outcome.recording.dir.empty()) write_session_report(outcome.recording.dir);
  return outcome.recording.exit_code;
}

}  // namespace pvcap
