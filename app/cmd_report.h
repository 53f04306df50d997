#pragma once
// `pvcap report SESSION [--json] [--no-self-check]`: the HTML session report written into the
// session folder (report.html), or its figures as JSON on stdout.
#include <filesystem>

namespace pvcap {

struct ReportCommand {
  std::filesystem::path session;
  bool json = false;
  bool self_check = true;
};

int cmd_report(const ReportCommand& c);

// After a recording: report.html written beside the store, its path printed. False (said, at error
// level) when it could not be made: the session's data is already safe, but the command ends in exit 1
// (a disk failing under the session must not pass unsaid).
bool write_session_report(const std::filesystem::path& session);

}  // namespace pvcap
