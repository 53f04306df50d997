#pragma once
// Everything `pvcap report` says about a session, as JSON, read from the store alone: what was
// captured and lost (reconciled with the store's tables), frame intervals, clock models, pairing,
// the protocol's takes, the calibration, and the sync self-check. The HTML report is made from it
// (report_html.h); `pvcap report --json` prints it. Keys are documented in docs/report.md.
#include <filesystem>
#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "core/result.h"

namespace pvcap::report {

struct ReportOptions {
  bool self_check = true;
  bool thumbnails = true;
  int max_self_check_presses = 12;  // spread over the session; bounds the frames decoded
  // Called now and then with what is being done and how far (done of total); may be empty.
  std::function<void(const std::string& what, std::size_t done, std::size_t total)> progress;
};

Result<nlohmann::json> build_report(const std::filesystem::path& session_dir, const ReportOptions& o = {});

}  // namespace pvcap::report
