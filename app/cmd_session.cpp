#include "app/cmd_session.h"

#include <unistd.h>
#include <thread>

#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "app/auto_participant.h"
#include "app/cmd_report.h"
#include "app/command.h"
#include "app/rig_launcher.h"
#include "core/durable_folder.h"
#include "report/session_text.h"
#include "storage/index/session_reader.h"

namespace pvcap {

namespace {

struct SessionArgs {
  std::string rig_path, root = "sessions", protocol, resume;
  std::optional<double> duration;
  ParticipantRecord participant;
  ConditionsRecord conditions;
  bool auto_participant = false, fast = false, board = false, no_web = false;
  console::WebOptions web;
  std::string web_token_file;
  bool root_given = false;
};

console::SessionSetup setup_from(const SessionArgs& a, const RigConfig& rig) {
  run_under_rig_preload(rig);  // before the pages' socket is bound: it may start this process again
  console::SessionSetup setup;
  if (!a.no_web) {
    // Bound here, before a simulated rig's private network namespace: the pages stay reachable
    // from this machine's own browser.
    const char* env_token = std::getenv("PVCAP_WEB_TOKEN");  // the token out of `ps`'s sight
    auto bound = console::WebConsole::bind(console::with_token(a.web, a.web_token_file, env_token ? env_token : ""));
    if (!bound) throw UserError(bound.error().message);
    setup.web = std::move(bound.value());
  }
  prepare_rig_network(rig);
  auto& opts = setup.recording;
  opts.root = a.root;
  setup.duration_s = a.duration;
  if (!a.protocol.empty()) setup.protocol = a.protocol;
  if (!a.resume.empty()) {
    setup.resume = a.resume;
    if (!a.root_given) opts.root.clear();  // beside the session it continues
  }
  setup.auto_participant = a.auto_participant;
  opts.board_session = a.board;
  setup.fast = a.fast;
  if (!a.participant.pseudonym.empty())
    opts.participant = a.participant;
  else if (!a.participant.skin_tone.empty() || !a.participant.hand_order.empty())
    throw UserError("--skin-tone and --hand-order describe a participant: give --participant too");
  if (!a.conditions.lighting.empty() || !a.conditions.sensor_overlay.empty()) opts.conditions = a.conditions;
  console::prepare_session(rig, setup);
  if ((setup.protocol || setup.continuation) && !setup.auto_participant && isatty(STDIN_FILENO) == 1)
    console::ask_for_participant(setup, std::cin, std::cout);
  return setup;
}

int run_session_command(const SessionArgs& a, AppContext& ctx) {
  if (a.rig_path.empty() && a.resume.empty())
    throw UserError(
        "pvcap session needs a rig: --rig RIG.yaml (or --resume SESSION, which records on the rig "
        "that session recorded)");
  const RigConfig rig = a.rig_path.empty() ? console::rig_of_session(a.resume) : load_rig_config(a.rig_path);
  console::SessionSetup setup = setup_from(a, rig);
  return report_recorded_session(record_session(rig, setup, ctx), ctx.faults.report_stall_s);
}

}  // namespace

console::SessionOutcome record_session(const RigConfig& rig, console::SessionSetup& setup, AppContext& ctx) {
  console::SessionOutcome failed;
  failed.recording.exit_code = 1;
  setup.recording.faults = ctx.faults;
  if (Status s = session::check_sessions_root(setup.recording.root); !s.ok()) {
    spdlog::error("{}", s.error().message);
    return failed;
  }
  auto launched =
      launch_rig(rig, {ctx.self_exe, setup.recording.root, setup.auto_participant, setup.recording.board_session});
  if (!launched) {
    spdlog::error("{}", launched.error().message);
    return failed;
  }
  LaunchedRig& devices = *launched.value();
  setup.recording.device_wait_s = devices.device_wait_s;
  setup.recording.sensel_ports_dir = devices.sensel_ports_dir;
  setup.recording.on_devices_stopped = [&devices] { devices.stop_devices(); };
  if (setup.auto_participant)
    setup.decorate_env = [&devices](std::unique_ptr<protocol::RunnerEnv> env) -> std::unique_ptr<protocol::RunnerEnv> {
      return std::make_unique<AutoParticipant>(std::move(env),
                                               [&devices](const sim::HandCommand& c) { return devices.steer(c); });
    };
  auto outcome = console::run_session(devices.rig, setup, ctx.stop);
  devices.file_truth(outcome.recording.dir);
  return outcome;
}

int report_recorded_session(const console::SessionOutcome& outcome, double report_stall_s) {
  const auto& rec = outcome.recording;
  if (rec.dir.empty()) return rec.exit_code;
  // The report the operator reads, from what the store holds (also kept as report.txt). A report that
  // cannot be made or written (the disk failing under the session) fails the command: exit 1, the
  // file and the error named; the recorded data stays as it is.
  const auto closing = report::closing_report(rec.dir, rec.recorded_s, rec.notes, outcome.protocol);
  int exit_code = closing.errors.empty() ? rec.exit_code : 1;
  for (const auto& e : closing.errors) spdlog::error("{}", e);
  // fputs, not fmt::print: a terminal that went away (a dropped ssh) is not an error here.
  std::fputs(closing.terminal.c_str(), stdout);
  if (Status s = write_file_atomically(rec.dir / "report.txt", closing.file, Durability::Renamed); !s.ok()) {
    spdlog::error("{}", s.error().message);
    exit_code = 1;
  }
  spdlog::info("report: writing report.html");
  if (report_stall_s > 0)  // a test's fault (core/fault_injection.h): the report held open
    std::this_thread::sleep_for(std::chrono::duration<double>(report_stall_s));
  if (!write_session_report(rec.dir)) exit_code = 1;
  return exit_code;
}

Registered add_session_command(CLI::App& app, AppContext& ctx) {
  auto a = std::make_shared<SessionArgs>();
  auto* s = app.add_subcommand("session", "record a session into a new session folder");
  s->add_option("--rig", a->rig_path,
                "rig description (rig-configs/*.yaml); with --resume, the session's own by "
                "default")
      ->check(CLI::ExistingFile);
  s->add_option("--root", a->root, "folder that receives the new session folder")->capture_default_str();
  s->add_option("--duration", a->duration, "stop after this many seconds (otherwise Ctrl-C stops)")
      ->check(CLI::PositiveNumber);
  s->add_option("--participant", a->participant.pseudonym, "the participant's pseudonymous code (never a name)");
  s->add_option("--skin-tone", a->participant.skin_tone, "skin-tone category")
      ->check(CLI::IsMember({"light", "medium", "dark", "unrecorded"}));
  s->add_option("--hand-order", a->participant.hand_order, "which hand does the protocol first")
      ->check(CLI::IsMember({"right_first", "left_first"}));
  s->add_option("--lighting", a->conditions.lighting, "lighting condition (which lights are on, e.g. LCR)");
  s->add_option("--overlay", a->conditions.sensor_overlay, "what covers the sensor (e.g. white_vinyl, wood)");
  s->add_option("--protocol", a->protocol, "run this action protocol (rig-configs/protocols/*.yaml)")
      ->check(CLI::ExistingFile);
  s->add_flag("--auto", a->auto_participant, "simulated rig: the simulated hand performs every prompted take");
  s->add_flag("--fast", a->fast, "the protocol's short timings (a few seconds a take), for demos and tests");
  s->add_flag("--board", a->board,
              "record a calibration board session (for `pvcap calibrate intrinsics`; a "
              "simulated rig moves its own board)");
  s->add_option("--resume", a->resume, "continue the protocol of this interrupted session in a new folder")
      ->check(CLI::ExistingDirectory);
  s->add_option("--web-bind", a->web.bind, "address the session's pages listen on")->capture_default_str();
  s->add_option("--web-port", a->web.port, "port of the session's pages (busy: another is taken and printed; 0: any)")
      ->capture_default_str()
      ->check(CLI::Range(0, 65535));
  s->add_option("--web-token", a->web.token,
                "token the pages require (default: generated and printed in the addresses); other users see it "
                "in `ps`: prefer --web-token-file or PVCAP_WEB_TOKEN");
  s->add_option("--web-token-file", a->web_token_file, "read the pages' token from this file's first line")
      ->check(CLI::ExistingFile);
  s->add_flag("--no-web-token", a->web.no_token,
              "loopback only: pages without a token (any local user or process can then watch and steer the "
              "session)");
  s->add_flag("--no-web", a->no_web, "serve no pages (the terminal console still works)");
  return {s, [a, s, &ctx] {
            a->root_given = s->count("--root") > 0;
            return run_session_command(*a, ctx);
          }};
}

}  // namespace pvcap
