// The store's own tools: `pvcap takes`, `pvcap verify`, `pvcap recover`, `pvcap migrate`.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "app/command.h"
#include "protocol/takes.h"
#include "session/realign.h"
#include "storage/recover.h"
#include "storage/verify.h"

namespace pvcap {

namespace {
void log_step(const std::string& step) { spdlog::info("{}", step); }
}  // namespace

Registered add_takes_command(CLI::App& app, AppContext&) {
  auto dir = std::make_shared<std::string>();
  auto json = std::make_shared<bool>(false);
  auto* t = app.add_subcommand("takes", "list the takes of a protocol session (and of the sessions it continues)");
  t->add_option("SESSION", *dir, "the session folder")->required()->check(CLI::ExistingDirectory);
  t->add_flag("--json", *json, "as JSON");
  return {t, [dir, json] {
            auto takes = protocol::read_takes(*dir);
            if (!takes) {
              spdlog::error("{}", takes.error().message);
              return 1;
            }
            if (*json)
              fmt::print("{}\n", protocol::takes_json(takes.value()).dump(2));
            else
              fmt::print("{}", protocol::format_takes(takes.value()));
            return 0;
          }};
}

Registered add_verify_command(CLI::App& app, AppContext&) {
  auto dir = std::make_shared<std::string>();
  auto* v = app.add_subcommand("verify",
                               "check a session folder: index against videos, pressure frames, samples; "
                               "exit 0 clean, 3 lossy but readable, 1 failed");
  v->add_option("SESSION", *dir, "the session folder")->required()->check(CLI::ExistingDirectory);
  return {v, [dir] {
            const auto report = verify_session(*dir, log_step);
            fmt::print("{}", format_report(*dir, report));
            return report.exit_code();
          }};
}

Registered add_recover_command(CLI::App& app, AppContext&) {
  auto dir = std::make_shared<std::string>();
  auto* r = app.add_subcommand("recover",
                               "make a session interrupted by a crash or kill readable (closes its videos, "
                               "marks what was lost; never deletes anything)");
  r->add_option("SESSION", *dir, "the session folder")->required()->check(CLI::ExistingDirectory);
  return {r, [dir] {
            auto done = recover_and_realign(*dir, log_step);
            if (!done) {
              spdlog::error("{}", done.error().message);
              return 1;
            }
            fmt::print("session {}\n", *dir);
            for (const auto& d : done.value()) fmt::print("  {}\n", d);
            if (done.value().empty())
              fmt::print("nothing to recover: the session ended cleanly\n");
            else
              fmt::print("recovered: 'pvcap verify {}' says what is there\n", *dir);
            return 0;
          }};
}

Registered add_migrate_command(CLI::App& app, AppContext&) {
  auto dir = std::make_shared<std::string>();
  auto* m = app.add_subcommand("migrate",
                               "upgrade a session written by an older pvcap (keeps a copy of the old "
                               "index)");
  m->add_option("SESSION", *dir, "the session folder")->required()->check(CLI::ExistingDirectory);
  return {m, [dir] {
            auto r = migrate_session(*dir, log_step);
            if (!r) {
              spdlog::error("{}", r.error().message);
              return 1;
            }
            for (const auto& d : r.value()) fmt::print("{}: {}\n", *dir, d);
            return 0;
          }};
}

}  // namespace pvcap
