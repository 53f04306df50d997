#include "console/session_command.h"

#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <istream>
#include <ostream>
#include <thread>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "console/board_coverage_monitor.h"
#include "console/recording_env.h"
#include "console/terminal_console.h"
#include "protocol/runner.h"
#include "protocol/takes.h"
#include "storage/index/session_reader.h"

namespace pvcap::console {

RigConfig rig_of_session(const std::filesystem::path& session) {
  auto reader = SessionReader::open(session);
  if (!reader) throw UserError(fmt::format("--resume {}: {}", session.string(), reader.error().message));
  const SessionInfo& info = reader.value()->info();
  std::error_code ec;
  if (!info.rig_path.empty() && std::filesystem::exists(info.rig_path, ec)) {
    RigConfig current = load_rig_config(info.rig_path);
    if (current.text == info.rig_config) return current;
    spdlog::warn(
        "{} changed since {} was recorded: the session continues with the rig it recorded (give --rig to "
        "use the file as it is now)",
        info.rig_path, session.string());
  }
  return parse_rig_config(info.rig_config,
                          info.rig_path.empty() ? session / "rig.yaml" : std::filesystem::path(info.rig_path));
}

void prepare_session(const RigConfig& rig, SessionSetup& c) {
  if (c.recording.board_session && (c.protocol || c.resume))
    throw UserError("--board records a calibration board session: it runs no protocol (leave out --protocol/--resume)");
  if (auto& p = c.recording.participant) {
    if (!is_pseudonymous_code(p->pseudonym))
      throw UserError(
          fmt::format("--participant '{}' does not look like a pseudonymous code: use 1 to 32 letters, "
                      "digits, '-' or '_' (e.g. P017), never a name",
                      p->pseudonym));
    if (p->skin_tone.empty()) p->skin_tone = "unrecorded";
    if (p->hand_order.empty()) p->hand_order = "unrecorded";
  }
  if (auto& k = c.recording.conditions) {
    if (k->lighting.empty()) k->lighting = "unrecorded";
    if (k->sensor_overlay.empty()) k->sensor_overlay = "unrecorded";
  }
  if (c.auto_participant && !rig.simulated)
    throw UserError(
        fmt::format("--auto needs a simulated rig ({} has no sim: section): on a real rig a participant "
                    "performs the takes",
                    rig.source.string()));
  if (c.auto_participant && !c.protocol && !c.resume)
    throw UserError("--auto performs a protocol: give --protocol FILE");
  if (!c.resume) return;
  // The resumed session's protocol, participant and conditions carry over, unless given again.
  auto takes = protocol::read_takes(*c.resume);
  if (!takes) throw UserError(fmt::format("--resume {}: {}", c.resume->string(), takes.error().message));
  auto reader = SessionReader::open(*c.resume);
  if (!reader) throw UserError(fmt::format("--resume {}: {}", c.resume->string(), reader.error().message));
  const auto& start = takes.value().protocol_start;
  Continuation k;
  k.previous = std::filesystem::absolute(*c.resume);
  k.first_step = protocol::first_incomplete_step(takes.value());
  k.protocol_text = start.value("text", "");
  k.protocol_file = start.value("file", "");
  k.hand_order = start.value("hand_order", "right_first");
  if (k.first_step >= takes.value().plan_steps)
    throw UserError(
        fmt::format("--resume {}: every take of its protocol is done; nothing to resume", c.resume->string()));
  if (!c.recording.participant && reader.value()->info().participant)
    c.recording.participant = reader.value()->info().participant;
  if (!c.recording.conditions && reader.value()->info().conditions)
    c.recording.conditions = reader.value()->info().conditions;
  if (c.recording.root.empty()) c.recording.root = k.previous.parent_path();
  c.fast = c.fast || start.value("fast", false);
  c.auto_participant = c.auto_participant || (start.value("auto", false) && rig.simulated);
  c.continuation = k;
}

namespace {

// Asks until the answer is accepted: one of `choices`, or (without choices) what `valid` accepts.
// Enter gives `fallback` when there is one. Throws when the input ends.
std::string ask(std::istream& in, std::ostream& out, const std::string& question,
                const std::vector<std::string>& choices, const std::string& fallback,
                bool (*valid)(const std::string&) = nullptr) {
  for (;;) {
    out << question;
    if (!choices.empty()) out << " [" << fmt::format("{}", fmt::join(choices, ", ")) << "]";
    if (!fallback.empty()) out << " (Enter: " << fallback << ")";
    out << ": " << std::flush;
    std::string answer;
    if (!std::getline(in, answer)) throw UserError("the participant's details were not given (the input ended)");
    answer.erase(0, answer.find_first_not_of(" \t"));
    answer.erase(answer.find_last_not_of(" \t\r") + 1);
    if (answer.empty() && !fallback.empty()) return fallback;
    if (std::find(choices.begin(), choices.end(), answer) != choices.end()) return answer;
    if (choices.empty() && valid && valid(answer)) return answer;
    out << "  not accepted: "
        << (choices.empty() ? "use 1 to 32 letters, digits, '-' or '_', no spaces (a participant: a code, never a name)"
                            : "answer one of the words in brackets")
        << "\n";
  }
}

}  // namespace

void ask_for_participant(SessionSetup& c, std::istream& in, std::ostream& out) {
  if (c.recording.participant && c.recording.conditions) return;
  out << "Before the protocol starts: the participant and the conditions of this session.\n";
  if (!c.recording.participant) {
    ParticipantRecord p;
    p.pseudonym = ask(in, out, "Participant code (pseudonymous, e.g. P017)", {}, "", is_pseudonymous_code);
    p.skin_tone = ask(in, out, "Skin tone", {"light", "medium", "dark", "unrecorded"}, "unrecorded");
    p.hand_order = ask(in, out, "Hand order", {"right_first", "left_first"}, "right_first");
    c.recording.participant = p;
  }
  if (!c.recording.conditions) {
    ConditionsRecord k;
    k.lighting = ask(in, out, "Lighting (which lights are on, e.g. LCR)", {}, "unrecorded", is_pseudonymous_code);
    k.sensor_overlay = ask(in, out, "Sensor overlay (e.g. white_vinyl)", {}, "unrecorded", is_pseudonymous_code);
    c.recording.conditions = k;
  }
}

SessionOutcome run_session(const RigConfig& rig, const SessionSetup& command, const std::atomic<bool>& interrupt) {
  // The protocol loads before any device is touched: a bad file costs no session.
  std::optional<protocol::Protocol> proto;
  if (command.continuation)
    proto = protocol::parse_protocol(command.continuation->protocol_text, command.continuation->protocol_file);
  else if (command.protocol)
    proto = protocol::load_protocol(*command.protocol);
  std::string hand_order = "right_first";
  if (command.continuation)
    hand_order = command.continuation->hand_order;
  else if (command.recording.participant && command.recording.participant->hand_order == "left_first")
    hand_order = "left_first";

  const session::RecordingOptions& options = command.recording;
  SessionOutcome outcome;
  outcome.recording.exit_code = 1;
  auto opened = session::Recording::open(rig, options, interrupt);
  if (!opened) {
    spdlog::error("{}", opened.error().message);
    return outcome;
  }
  session::Recording& recording = *opened.value();
  if (Status s = recording.start(); !s.ok()) {
    spdlog::error("{}", s.error().message);
    return outcome;
  }

  // A board session tells the operator, as it goes, which cameras' views would give a lens.
  std::unique_ptr<BoardCoverageMonitor> board;
  if (options.board_session) board = std::make_unique<BoardCoverageMonitor>(recording);

  std::unique_ptr<protocol::RunnerEnv> env;
  std::unique_ptr<protocol::Runner> runner;
  std::thread ticker;
  std::atomic<bool> ticking{true};
  if (proto) {
    nlohmann::json detail = {{"protocol", proto->name},
                             {"file", proto->source.string()},
                             {"hand_order", hand_order},
                             {"fast", command.fast},
                             {"auto", command.auto_participant},
                             {"takes", protocol::make_plan(*proto, hand_order).size()},
                             {"text", proto->text}};
    protocol::RunnerOptions ro;
    ro.auto_start = command.auto_participant;
    ro.auto_advance = command.auto_participant;
    ro.fast = command.fast;
    ro.lighting = recording.lighting_now();  // the session's, switched at its start (docs/lighting.md)
    if (command.continuation) {
      ro.first_step = command.continuation->first_step;
      detail["continues"] = command.continuation->previous.string();
      detail["first_step"] = command.continuation->first_step;
      spdlog::info("resuming {} at take {} of {}", command.continuation->previous.string(),
                   command.continuation->first_step + 1, 2 * proto->actions.size());
    }
    ro.protocol_detail = detail.dump();
    env = std::make_unique<RecordingEnv>(recording);
    if (command.decorate_env) env = command.decorate_env(std::move(env));
    runner = std::make_unique<protocol::Runner>(*proto, hand_order, *env, ro);
    ticker = std::thread([&] {
      std::string last_message;
      while (ticking.load()) {
        runner->tick();
        const auto v = runner->view();
        if (v.message != last_message && !v.message.empty()) {
          spdlog::info("protocol: {}", v.message);
          last_message = v.message;
        }
        if (runner->finished()) {
          recording.request_stop(v.phase == protocol::Phase::Done ? "protocol complete" : "protocol aborted");
          break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      }
    });
  }

  RecordingPages pages(recording);  // outlives the pages' stop() below
  if (command.web) {
    command.web->serve(pages, runner.get());
    spdlog::info("participant display: {}", command.web->url("participant"));
    spdlog::info("operator console:    {}", command.web->url("operator"));
    const std::string api = command.web->url("api/v1/");
    spdlog::info("remote-control API:  {} (docs/remote.md: the same token, as a bearer token)",
                 api.substr(0, api.find('?')));
  }

  // The operator's keyboard, when pvcap runs in a terminal.
  std::unique_ptr<TerminalConsole> console;
  std::thread console_thread;
  std::atomic<bool> console_stop{false};
  if (runner && TerminalConsole::available()) {
    console = std::make_unique<TerminalConsole>(*runner);
    console_thread = std::thread([&] { console->run(console_stop); });
  } else if (runner && !command.auto_participant) {
    spdlog::warn(
        "no terminal to read the operator's keys from: the protocol waits for a start that cannot come "
        "(run pvcap in a terminal, or with --auto on a simulated rig)");
  }

  const std::string reason = recording.wait(interrupt, command.duration_s);
  if (board) {
    for (const std::string& line : board->summary()) spdlog::info("board coverage: {}", line);
    board.reset();
  }
  ticking.store(false);
  if (ticker.joinable()) ticker.join();
  console_stop.store(true);
  if (console_thread.joinable()) console_thread.join();
  console.reset();
  if (command.web) command.web->stop();  // the pages end before what they show
  if (runner && !runner->finished()) {
    // Stopped before the protocol's end: the take being recorded is closed as interrupted.
    (void)runner->command(protocol::Command::Abort, reason);
  }
  outcome.recording = recording.finish(reason);
  outcome.protocol = bool(runner);
  return outcome;
}

}  // namespace pvcap::console
