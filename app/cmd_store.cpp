// The store's own tools: `pvcap takes`, `pvcap verify`, `pvcap recover`, `pvcap migrate`,
// `pvcap compact`.
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <thread>

#include "app/command.h"
#include "console/progress_line.h"
#include "protocol/takes.h"
#include "session/realign.h"
#include "storage/tools/compact.h"
#include "storage/tools/verify.h"
#include "storage/writer/recover.h"

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

Registered add_recover_command(CLI::App& app, AppContext& ctx) {
  auto dir = std::make_shared<std::string>();
  auto* r = app.add_subcommand("recover",
                               "make a session interrupted by a crash or kill readable (closes its videos, "
                               "marks what was lost; never deletes anything)");
  r->add_option("SESSION", *dir, "the session folder")->required()->check(CLI::ExistingDirectory);
  return {r, [dir, &ctx] {
            bool stalled = false;
            auto step = [&](const std::string& line) {
              log_step(line);
              if (stalled || ctx.faults.recover_stall_s <= 0) return;
              stalled = true;  // a test's fault (core/fault_injection.h): recover held open after its first step
              spdlog::info("recover: paused by the test fault recover.stall_s");
              std::this_thread::sleep_for(std::chrono::duration<double>(ctx.faults.recover_stall_s));
            };
            auto done = recover_and_realign(*dir, step);
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

Registered add_compact_command(CLI::App& app, AppContext& ctx) {
  auto dirs = std::make_shared<std::vector<std::string>>();
  auto o = std::make_shared<CompactOptions>();
  auto* c = app.add_subcommand("compact",
                               "re-encode finished sessions' raw videos to a denser lossless codec, every frame "
                               "checked bit for bit before an old file is removed (safe to stop at any moment)");
  c->add_option("SESSION", *dirs, "session folders, one after another")->required()->check(CLI::ExistingDirectory);
  auto purpose = std::make_shared<std::string>();
  c->add_option("--for", *purpose,
                "archive: the fewest bytes (libx264, inter prediction; shuffled reads decode from a key frame); "
                "training: crops read as fast as the live store, for fewer bytes than it (ffvhuff, tiles)")
      ->check(CLI::IsMember({"archive", "training"}));
  c->add_option("--codec", o->codec, "libx264 (= --for archive), ffvhuff (= --for training) or ffv1 (intra only)")
      ->check(CLI::IsMember({"libx264", "ffvhuff", "ffv1"}))
      ->capture_default_str();
  c->add_option("--preset", o->preset, "libx264's preset: slower is smaller")->capture_default_str();
  c->add_option("--gop", o->gop_frames, "frames between key frames (what a random read decodes at most)")
      ->check(CLI::Range(1, 600))
      ->capture_default_str();
  c->add_option("--threads", o->threads, "encoder threads")->check(CLI::Range(1, 64))->capture_default_str();
  return {c, [dirs, o, purpose, &ctx] {
            if (!purpose->empty()) o->codec = *purpose == "training" ? "ffvhuff" : "libx264";
            int failed = 0;
            for (const auto& dir : *dirs) {
              console::ProgressLine line;
              CompactOptions options = *o;
              options.stop = &ctx.stop;
              const auto started = std::chrono::steady_clock::now();
              options.progress = [&](const std::string& segment, std::int64_t done, std::int64_t total,
                                     std::int64_t all_done, std::int64_t all_total) {
                const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
                const double rate = s > 0 ? double(all_done) / s : 0;
                line.show(fmt::format("compact: {} {}/{} frames; session {}/{} frames, {:.1f} frames/s, {:.0f} s left",
                                      segment, done, total, all_done, all_total, rate,
                                      rate > 0 ? double(all_total - all_done) / rate : 0),
                          std::size_t(all_done), std::size_t(all_total));
              };
              auto r = compact_session(dir, options);
              if (!r) {
                line.abandon();
                spdlog::error("{}", r.error().message);
                ++failed;
                continue;
              }
              if (r.value().stopped) line.abandon();
              fmt::print("{}", describe_compact_report(dir, r.value()));
              if (r.value().stopped) return 130;
            }
            return failed ? 1 : 0;
          }};
}

}  // namespace pvcap
