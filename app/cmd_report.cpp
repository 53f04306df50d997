#include "app/cmd_report.h"
#include "app/command.h"

#include <unistd.h>

#include <chrono>
#include <cstdio>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "report/report_html.h"
#include "report/session_report_data.h"

namespace pvcap {

namespace {

// One line on stderr, rewritten as the work goes on (stdout stays clean for --json); only on a
// terminal, where a rewritten line reads as progress rather than noise.
void progress(const std::string& what, std::size_t done, std::size_t total) {
  static const bool terminal = isatty(STDERR_FILENO) == 1;
  if (!terminal) return;
  fmt::print(stderr, "\r{}: {}/{}\x1b[K{}", what, done, total, done >= total ? "\n" : "");
  std::fflush(stderr);
}

}  // namespace

int cmd_report(const ReportCommand& c) {
  report::ReportOptions o;
  o.self_check = c.self_check;
  o.progress = progress;
  const auto started = std::chrono::steady_clock::now();
  if (c.json) {
    auto data = report::build_report(c.session, o);
    if (!data) {
      spdlog::error("{}", data.error().message);
      return 1;
    }
    fmt::print("{}\n", data.value().dump(2));
    return 0;
  }
  auto written = report::write_html_report(c.session, o);
  if (!written) {
    spdlog::error("{}", written.error().message);
    return 1;
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  fmt::print("report: {} ({:.0f} kB, made in {:.1f} s)\n", written.value().string(),
             double(std::filesystem::file_size(written.value())) / 1e3, s);
  return 0;
}

bool write_session_report(const std::filesystem::path& session) {
  std::fflush(stdout);
  report::ReportOptions o;
  o.progress = progress;
  auto written = report::write_html_report(session, o);
  if (!written) {
    spdlog::error(
        "the HTML report could not be made ({}); the session's data is kept, and `pvcap report {}` tries "
        "again",
        written.error().message, session.string());
    return false;
  }
  fmt::print("full report (plots, sync self-check, calibration): {}\n", written.value().string());
  return true;
}

Registered add_report_command(CLI::App& app, AppContext&) {
  auto c = std::make_shared<ReportCommand>();
  auto no_self_check = std::make_shared<bool>(false);
  auto* r = app.add_subcommand("report",
                               "the session report: report.html in the session folder (captured and lost, "
                               "intervals, clocks, pairing, takes, calibration, sync self-check)");
  r->add_option("SESSION", c->session, "the session folder")->required()->check(CLI::ExistingDirectory);
  r->add_flag("--json", c->json, "print the report's figures as JSON instead of writing the page");
  r->add_flag("--no-self-check", *no_self_check, "leave out the sync self-check (it decodes frames around presses)");
  return {r, [c, no_self_check] {
            c->self_check = !*no_self_check;
            return cmd_report(*c);
          }};
}

}  // namespace pvcap
