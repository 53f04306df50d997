#include "app/cmd_session.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace pvcap {

int run_session(const RigConfig& rig, const SessionCommand& command, const std::atomic<bool>& interrupt) {
  auto opened = session::Recording::open(rig, command.recording, interrupt);
  if (!opened) {
    spdlog::error("{}", opened.error().message);
    return 1;
  }
  session::Recording& recording = *opened.value();
  if (Status s = recording.start(); !s.ok()) {
    spdlog::error("{}", s.error().message);
    return 1;
  }
  const std::string reason = recording.wait(interrupt, command.duration_s);
  const auto result = recording.finish(reason);
  fmt::print("\n{}", result.report);
  return result.exit_code;
}

}  // namespace pvcap
