// pvcap: capture and synchronization for visual hand-pressure datasets.
// Thin: parses the command line, wires modules, runs. See docs/ for the user guide.
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <iostream>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "app/cmd_devices.h"
#include "app/cmd_eval_sync.h"
#include "app/cmd_export.h"
#include "app/cmd_replay.h"
#include "app/cmd_report.h"
#include "app/cmd_sensel_decode.h"
#include "app/cmd_session.h"
#include "app/cmd_sim.h"
#include "calib/rig_calibration.h"
#include "calib/session_calibration.h"
#include "core/log.h"
#include "core/result.h"
#include "core/rig_config.h"
#include "core/version.h"
#include "protocol/takes.h"
#include "sim/sim_rig.h"
#include "session/realign.h"
#include "storage/recover.h"
#include "storage/verify.h"

namespace {

std::atomic<bool> g_stop{false};

void on_signal(int) {
  if (g_stop.exchange(true)) _exit(130);  // a second Ctrl-C: leave now
}

void install_stop_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGHUP, &sa, nullptr);  // an ssh connection that drops stops the session cleanly
  signal(SIGPIPE, SIG_IGN);         // a closed pipe or socket is an error return, not death
}

std::filesystem::path self_exe() {
  std::error_code ec;
  auto p = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::filesystem::path("pvcap") : p;
}

// The simulated rig's network namespace (sim/sim_rig.h). Must run before any thread starts.
void ensure_sim_network(const pvcap::RigConfig& rig) {
  if (pvcap::Status s = pvcap::sim::ensure_network(rig); !s.ok()) throw pvcap::UserError(s.error().message);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"pvcap: capture and synchronization for visual hand-pressure datasets", "pvcap"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(pvcap::kVersion));
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "console log level: trace, debug, info, warn, error, off")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "off"}));

  auto* devices = app.add_subcommand("devices", "list the cameras (and sensors) this machine can reach");
  bool devices_json = false;
  std::string devices_sim;
  devices->add_flag("--json", devices_json, "one JSON object per device");
  std::vector<std::string> devices_ttys;
  devices->add_option("--tty", devices_ttys, "also ask the Sensel on these serial ports (e.g. /dev/serial/by-id/...)");
  devices->add_option("--sim", devices_sim, "first start this simulated rig (a rig file with a sim: section)")
      ->check(CLI::ExistingFile);

  auto* session = app.add_subcommand("session", "record a session into a new session folder");
  std::string rig_path;
  std::string root = "sessions";
  std::optional<double> duration;
  session->add_option("--rig", rig_path, "rig description (rig-configs/*.yaml)")->required()->check(CLI::ExistingFile);
  session->add_option("--root", root, "folder that receives the new session folder")->capture_default_str();
  session->add_option("--duration", duration, "stop after this many seconds (otherwise Ctrl-C stops)")
      ->check(CLI::PositiveNumber);

  pvcap::ParticipantRecord participant;
  pvcap::ConditionsRecord conditions;
  session->add_option("--participant", participant.pseudonym, "the participant's pseudonymous code (never a name)");
  session->add_option("--skin-tone", participant.skin_tone, "skin-tone category")
      ->check(CLI::IsMember({"light", "medium", "dark", "unrecorded"}));
  session->add_option("--hand-order", participant.hand_order, "which hand does the protocol first")
      ->check(CLI::IsMember({"right_first", "left_first"}));
  session->add_option("--lighting", conditions.lighting, "lighting condition (which lights are on, e.g. LCR)");
  session->add_option("--overlay", conditions.sensor_overlay, "what covers the sensor (e.g. white_vinyl, wood)");
  std::string protocol_path, resume_dir;
  bool auto_participant = false, fast = false;
  session->add_option("--protocol", protocol_path, "run this action protocol (rig-configs/protocols/*.yaml)")
      ->check(CLI::ExistingFile);
  session->add_flag("--auto", auto_participant, "simulated rig: the simulated hand performs every prompted take");
  session->add_flag("--fast", fast, "the protocol's short timings (a few seconds a take), for demos and tests");
  bool board_session = false;
  session->add_flag("--board", board_session, "record a calibration board session (for `pvcap calibrate intrinsics`; a "
                                              "simulated rig moves its own board)");
  session->add_option("--resume", resume_dir, "continue the protocol of this interrupted session in a new folder")
      ->check(CLI::ExistingDirectory);

  pvcap::protocol::WebOptions web;
  bool no_web = false;
  session->add_option("--web-bind", web.bind, "address the session's pages listen on (another than loopback needs a "
                                              "token)")->capture_default_str();
  session->add_option("--web-port", web.port, "port of the session's pages (busy: another is taken and printed; 0: "
                                              "any)")->capture_default_str()->check(CLI::Range(0, 65535));
  session->add_option("--web-token", web.token, "token the pages require (generated when binding off loopback)");
  session->add_flag("--no-web", no_web, "serve no pages (the terminal console still works)");

  auto* takes = app.add_subcommand("takes", "list the takes of a protocol session (and of the sessions it continues)");
  std::string takes_dir;
  bool takes_as_json = false;
  takes->add_option("SESSION", takes_dir, "the session folder")->required()->check(CLI::ExistingDirectory);
  takes->add_flag("--json", takes_as_json, "as JSON");

  auto* report = app.add_subcommand("report", "the session report: report.html in the session folder (captured and "
                                             "lost, intervals, clocks, pairing, takes, calibration, sync self-check)");
  pvcap::ReportCommand report_cmd;
  report->add_option("SESSION", report_cmd.session, "the session folder")->required()->check(CLI::ExistingDirectory);
  report->add_flag("--json", report_cmd.json, "print the report's figures as JSON instead of writing the page");
  bool no_self_check = false;
  report->add_flag("--no-self-check", no_self_check, "leave out the sync self-check (it decodes frames around presses)");

  auto* replay_cmd = app.add_subcommand("replay", "render a recorded session into a video (the camera views with the "
                                                  "pressure overlaid through each calibration, the pressure image, "
                                                  "the take, hand, force and time), or re-serve it through the "
                                                  "simulated devices (--as-devices); without either, in a window "
                                                  "(keys: space, arrows, [ ], p n, - +, q)");
  pvcap::ReplayCommand replay_opts;
  std::string replay_take;
  double replay_from = -1, replay_to = -1;
  replay_cmd->add_option("SESSION", replay_opts.session, "a session folder")->required()->check(CLI::ExistingDirectory);
  replay_cmd->add_option("--out", replay_opts.options.out, "the video to write (.mp4, or .mkv)");
  replay_cmd->add_flag("--as-devices", replay_opts.as_devices,
                       "write a rig file whose simulated devices re-serve the session through the cameras' and the "
                       "Sensel's own protocols; `pvcap session` on it records the session again");
  replay_cmd->add_option("--rate", replay_opts.rate,
                         "--as-devices: play this much faster (default 1: the original timing; the round trip is "
                         "exact only at 1, as the device timestamps are scaled so the clocks keep their own rate)")
      ->check(CLI::Range(0.1, 10.0));
  replay_cmd->add_option("--keys", replay_opts.window.keys, "the window: press these keys first (space, right, "
                                                           "left, n, p, +, -, q, ...; for demos and tests)")
      ->delimiter(',');
  replay_cmd->add_option("--snapshot", replay_opts.window.snapshot, "the window: write its last picture here (PNG)");
  replay_cmd->add_option("--rig-out", replay_opts.rig_out, "--as-devices: the rig file to write (default "
                                                           "./SESSION-replay.yaml)");
  replay_cmd->add_option("--take", replay_take, "only this take (its name, as `pvcap takes` lists it)");
  replay_cmd->add_option("--from", replay_from, "from this many seconds after the session's start");
  replay_cmd->add_option("--to", replay_to, "up to this many seconds after the session's start");
  replay_cmd->add_option("--speed", replay_opts.options.speed, "playback speed (2: twice as fast; default 1)")
      ->check(CLI::PositiveNumber);
  replay_cmd->add_option("--pressure-max", replay_opts.options.pressure_full_scale_kpa,
                         "pressure at the colour map's top, kPa (default 60)")
      ->check(CLI::PositiveNumber);
  auto* export_cmd = app.add_subcommand("export", "write sessions in the PressureVisionDB layout (the released loaders "
                                                  "read them unchanged); one independent job per session");
  pvcap::ExportCommand export_opts;
  std::string export_layout = "pressurevision", force_format = "pkl";
  std::vector<std::size_t> export_cameras;
  double export_from = -1, export_to = -1;
  export_cmd->add_option("SESSION", export_opts.sessions, "session folders")->required()->check(CLI::ExistingDirectory);
  export_cmd->add_option("--layout", export_layout, "pressurevision (metadata.json) or pressurevision-plus (meta.json, "
                                                    "a homography per frame)")
      ->check(CLI::IsMember({"pressurevision", "pressurevision-plus"}));
  export_cmd->add_option("--out", export_opts.options.out, "the dataset folder (shared by many sessions)")->required();
  std::string export_take;
  export_cmd->add_option("--take", export_take, "only this take (its sequence name, as `pvcap takes` lists it)");
  export_cmd->add_option("--from", export_from, "only samples from this many seconds after the session's start");
  export_cmd->add_option("--to", export_to, "only samples before this many seconds after the session's start");
  export_cmd->add_option("--cameras", export_cameras, "only these cameras (0-based indices, e.g. --cameras 0 2)");
  export_cmd->add_option("--jpeg-quality", export_opts.options.jpeg_quality, "JPEG quality, 1..100 (default 95)")
      ->check(CLI::Range(1, 100));
  export_cmd->add_option("--force-format", force_format, "pkl (what the loaders read, default) or npy")
      ->check(CLI::IsMember({"pkl", "npy"}));
  export_cmd->add_flag("--crop-paper", export_opts.options.paper_crop,
                       "the paper's crop: each frame cut to the pad + 50 px, 480 x 384 (intrinsics adjusted)");
  export_cmd->add_flag("--include-all", export_opts.options.include_all,
                       "also superseded, bad and interrupted takes (done takes only by default)");

  auto* sim = app.add_subcommand("sim", "serve a simulated rig (GigE Vision cameras over loopback)");
  std::string sim_rig, truth = "sim-truth";
  std::optional<double> sim_duration;
  sim->add_option("--rig", sim_rig, "rig file with a sim: section")->required()->check(CLI::ExistingFile);
  sim->add_option("--truth", truth, "folder for the ground truth of the run")->capture_default_str();
  sim->add_option("--duration", sim_duration, "stop after this many seconds")->check(CLI::PositiveNumber);
  bool sim_hand_commands = false;
  sim->add_flag("--hand-commands", sim_hand_commands, "steer the simulated hand by commands on stdin (one a line)");
  bool sim_board = false;
  sim->add_flag("--board", sim_board, "the cameras see the calibration board moving through its poses");

  auto* calibrate = app.add_subcommand("calibrate", "camera intrinsics from a board session, the pad's pose and "
                                                     "homography from any session showing the mat");
  calibrate->require_subcommand(1);
  auto* cal_board = calibrate->add_subcommand("board", "write the ChArUco board to print (.pdf or .png)");
  std::string board_out;
  cal_board->add_option("--out", board_out, "board.pdf or board.png")->required();
  auto* cal_intrinsics = calibrate->add_subcommand("intrinsics", "each camera's lens from a board session "
                                                                 "(pvcap session --board)");
  auto* cal_pad = calibrate->add_subcommand("pad", "the pad's pose and homography in each camera from the mat's "
                                                   "markers, with the intrinsics of a calibration file");
  auto* cal_check = calibrate->add_subcommand("check", "the press check: each press's pressure centroid against the "
                                                       "fingertip seen in each camera, through the calibration");
  pvcap::calib::SessionCalibrationOptions cal_opts;
  std::string cal_rig;
  for (auto* c : {cal_intrinsics, cal_pad, cal_check}) {
    c->add_option("SESSION", cal_opts.session, "the session folder")->required()->check(CLI::ExistingDirectory);
    c->add_option("--rig", cal_rig, "the rig file: the calibration file defaults to <rig>.calibration.yaml beside "
                                    "it (otherwise SESSION/calibration.yaml)")->check(CLI::ExistingFile);
    c->add_option("--ground-truth", cal_opts.ground_truth, "a simulated run's sim-truth folder: print the errors "
                                                           "against it and exit 1 above target")
        ->check(CLI::ExistingDirectory);
    c->add_option("--frames", cal_opts.frames, "frames per camera to look at, spread over the session")
        ->check(CLI::Range(1, 100000));
  }
  cal_intrinsics->add_option("--out", cal_opts.calibration, "the calibration file to write (updated if it exists)");
  cal_pad->add_option("--calibration", cal_opts.calibration, "the calibration file with the intrinsics (updated "
                                                             "with the pose)");
  cal_check->add_option("--calibration", cal_opts.calibration, "the calibration file to check");

  auto* sensel = app.add_subcommand("sensel", "Sensel Morph tools");
  sensel->require_subcommand(1);
  auto* sensel_decode = sensel->add_subcommand("decode", "decode a Sensel wire dump (.json or .jsonl) and summarise it");
  std::vector<std::string> decode_files;
  sensel_decode->add_option("FILE", decode_files, "capture files")->required()->check(CLI::ExistingFile);

  auto* eval = app.add_subcommand(
      "eval-sync", "record a simulated session with a hard timing scenario and measure the timeline against its truth");
  pvcap::EvalSyncOptions eval_opts;
  std::string eval_root;
  eval->add_option("--seconds", eval_opts.scenario.seconds, "length of the recording")->capture_default_str()
      ->check(CLI::Range(5.0, 3600.0));
  eval->add_option("--drift-ppm", eval_opts.scenario.drift_ppm, "camera clock drift (+- this; the Sensel half of it)")
      ->capture_default_str()->check(CLI::Range(0.0, 1000.0));
  eval->add_option("--jitter-ms", eval_opts.scenario.jitter_ms, "Sensel USB arrival jitter cap (long tail; mean a quarter)")
      ->capture_default_str()->check(CLI::Range(0.0, 50.0));
  eval->add_option("--loss", eval_opts.scenario.loss, "fraction of pressure frames the device loses")->capture_default_str()
      ->check(CLI::Range(0.0, 0.5));
  eval->add_option("--seed", eval_opts.scenario.seed, "scenario seed")->capture_default_str();
  eval->add_option("--warmup", eval_opts.warmup_s, "seconds at the start left out of the timing errors")
      ->capture_default_str()->check(CLI::Range(0.0, 60.0));
  eval->add_option("--root", eval_root, "folder for the scenario and its session (default: a new temporary one)");

  auto* verify = app.add_subcommand("verify", "check a session folder: index against videos, pressure frames, "
                                               "samples; exit 0 clean, 3 lossy but readable, 1 failed");
  std::string verify_dir;
  verify->add_option("SESSION", verify_dir, "the session folder")->required()->check(CLI::ExistingDirectory);

  auto* recover = app.add_subcommand("recover", "make a session interrupted by a crash or kill readable (closes its "
                                                 "videos, marks what was lost; never deletes anything)");
  std::string recover_dir;
  recover->add_option("SESSION", recover_dir, "the session folder")->required()->check(CLI::ExistingDirectory);
  auto* migrate = app.add_subcommand("migrate", "upgrade a session written by an older pvcap (keeps a copy of the "
                                                "old index)");
  std::string migrate_dir;
  migrate->add_option("SESSION", migrate_dir, "the session folder")->required()->check(CLI::ExistingDirectory);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; any mistake on the command line (a missing rig file too) exits 2.
    return app.exit(e) == 0 ? 0 : 2;
  }
  pvcap::log::init_console(log_level);
  install_stop_handlers();
  try {
    if (*devices) {
      if (devices_sim.empty()) return pvcap::cmd_devices(devices_json, devices_ttys);
      const auto rig = pvcap::load_rig_config(devices_sim);
      ensure_sim_network(rig);
      return pvcap::cmd_devices_of_sim(devices_json, rig);
    }
    if (*session) {
      const auto rig = pvcap::load_rig_config(rig_path);
      pvcap::protocol::SessionSetup command;
      if (!no_web) {
        // Bound here, before a simulated rig's private network namespace: the pages stay reachable
        // from this machine's own browser.
        if (!web.token.empty() && web.token.size() < 8)
          throw pvcap::UserError("--web-token must be at least 8 characters");
        auto bound = pvcap::protocol::WebConsole::bind(web);
        if (!bound) throw pvcap::UserError(bound.error().message);
        command.web = std::move(bound.value());
      }
      if (rig.sim) ensure_sim_network(rig);
      auto& opts = command.recording;
      opts.root = root;
      opts.device_wait_s = rig.sim ? 10.0 : 0.0;
      opts.self_exe = self_exe();
      command.duration_s = duration;
      if (!protocol_path.empty()) command.protocol = protocol_path;
      if (!resume_dir.empty()) {
        command.resume = resume_dir;
        if (session->count("--root") == 0) opts.root.clear();  // beside the session it continues
      }
      command.auto_participant = auto_participant;
      opts.board_session = board_session;
      command.fast = fast;
      if (!participant.pseudonym.empty()) opts.participant = participant;
      else if (!participant.skin_tone.empty() || !participant.hand_order.empty())
        throw pvcap::UserError("--skin-tone and --hand-order describe a participant: give --participant too");
      if (!conditions.lighting.empty() || !conditions.sensor_overlay.empty()) opts.conditions = conditions;
      pvcap::protocol::prepare_session(rig, command);
      if ((command.protocol || command.continuation) && !command.auto_participant && isatty(STDIN_FILENO) == 1)
        pvcap::protocol::ask_for_participant(command, std::cin, std::cout);
      return pvcap::cmd_session(rig, command, g_stop);
    }
    if (*eval) {
      eval_opts.root = eval_root.empty()
                           ? std::filesystem::temp_directory_path() / fmt::format("pvcap-eval-sync-{}", getpid())
                           : std::filesystem::path(eval_root);
      eval_opts.self_exe = self_exe();
      const auto scenario = pvcap::sim::write_eval_scenario(eval_opts.scenario, eval_opts.root);
      ensure_sim_network(pvcap::load_rig_config(scenario));
      spdlog::info("eval-sync: scenario {}, {:g} s", scenario.string(), eval_opts.scenario.seconds);
      return pvcap::eval_sync(scenario, eval_opts, g_stop);
    }
    if (*takes) {
      auto t = pvcap::protocol::read_takes(takes_dir);
      if (!t) {
        spdlog::error("{}", t.error().message);
        return 1;
      }
      if (takes_as_json) fmt::print("{}\n", pvcap::protocol::takes_json(t.value()).dump(2));
      else fmt::print("{}", pvcap::protocol::format_takes(t.value()));
      return 0;
    }
    if (*report) {
      report_cmd.self_check = !no_self_check;
      return pvcap::cmd_report(report_cmd);
    }
    if (*replay_cmd) {
      if (!replay_take.empty()) replay_opts.options.take = replay_take;
      if (replay_from >= 0) replay_opts.options.from_s = replay_from;
      if (replay_to >= 0) replay_opts.options.to_s = replay_to;
      return pvcap::cmd_replay(replay_opts, g_stop);
    }
    if (*export_cmd) {
      auto& o = export_opts.options;
      o.layout = export_layout == "pressurevision" ? pvcap::exporting::Layout::PressureVision
                                                   : pvcap::exporting::Layout::PressureVisionPlus;
      o.npy = force_format == "npy";
      o.cameras = export_cameras;
      if (!export_take.empty()) o.take = export_take;
      if (export_from >= 0) o.from_s = export_from;
      if (export_to >= 0) o.to_s = export_to;
      return pvcap::cmd_export(export_opts, g_stop);
    }
    if (*verify) {
      const auto report = pvcap::verify_session(verify_dir, [](const std::string& step) { spdlog::info("{}", step); });
      fmt::print("{}", pvcap::format_report(verify_dir, report));
      return report.exit_code();
    }
    if (*recover) {
      auto done = pvcap::recover_and_realign(recover_dir, [](const std::string& step) { spdlog::info("{}", step); });
      if (!done) {
        spdlog::error("{}", done.error().message);
        return 1;
      }
      fmt::print("session {}\n", recover_dir);
      for (const auto& d : done.value()) fmt::print("  {}\n", d);
      if (done.value().empty()) fmt::print("nothing to recover: the session ended cleanly\n");
      else fmt::print("recovered: 'pvcap verify {}' says what is there\n", recover_dir);
      return 0;
    }
    if (*migrate) {
      auto r = pvcap::migrate_session(migrate_dir, [](const std::string& step) { spdlog::info("{}", step); });
      if (!r) {
        spdlog::error("{}", r.error().message);
        return 1;
      }
      for (const auto& d : r.value()) fmt::print("{}: {}\n", migrate_dir, d);
      return 0;
    }
    if (*cal_board) return pvcap::calib::write_board(board_out);
    if (*cal_intrinsics || *cal_pad || *cal_check) {
      if (cal_opts.calibration.empty() && !cal_rig.empty())
        cal_opts.calibration = pvcap::calib::default_calibration_path(cal_rig);
      if (*cal_check) return pvcap::calib::check_against_presses(cal_opts);
      return *cal_pad ? pvcap::calib::pad_from_session(cal_opts) : pvcap::calib::intrinsics_from_session(cal_opts);
    }
    if (*sensel_decode) {
      int rc = 0;
      for (const auto& f : decode_files) {
        auto summary = pvcap::sensel::summarise_capture_file(f);
        if (!summary) throw pvcap::UserError(summary.error().message);
        rc = std::max(rc, pvcap::print_sensel_summary(f, summary.value()));
      }
      return rc;
    }
    if (*sim) {
      const auto rig = pvcap::load_rig_config(sim_rig);
      if (!rig.sim) throw pvcap::UserError(fmt::format("{}: has no sim: section", sim_rig));
      ensure_sim_network(rig);
      return pvcap::cmd_sim(rig, truth, sim_duration, sim_hand_commands, sim_board, g_stop);
    }
  } catch (const pvcap::UserError& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  return 0;
}
