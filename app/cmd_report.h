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

// After a recording: report.html written beside the store, its path printed; a failure is logged,
// never fatal (the session is already safe).
// False (said, at error level) when it could not be written: a disk failing under the session.
bool write_session_report(const std::filesystem::path& session);

}  // namespace pvcap
