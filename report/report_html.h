#pragma once
// The session report as one self-contained HTML page (inline SVG plots and images, no scripts,
// nothing fetched), made from build_report's JSON.
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "core/result.h"
#include "report/session_report_data.h"

namespace pvcap::report {

std::string render_html(const nlohmann::json& report);

// Text as HTML (& < > " escaped): what a store or a file names is never markup.
std::string html_escape(const std::string& s);

// Builds the report of a session and writes it as SESSION/report.html (through a temporary file
// renamed over it: a reader never sees half a page). Returns the file's path.
Result<std::filesystem::path> write_html_report(const std::filesystem::path& session_dir, const ReportOptions& o = {});

}  // namespace pvcap::report
