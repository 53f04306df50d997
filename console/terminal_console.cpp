#include "console/terminal_console.h"

#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <cstring>
#include <iostream>
#include <string>

#include <spdlog/spdlog.h>

namespace pvcap::console {

using protocol::Command;
using protocol::Phase;
using protocol::Runner;

static_assert(sizeof(termios) <= 64, "termios must fit the saved bytes");

bool TerminalConsole::available() { return isatty(STDIN_FILENO) == 1; }

const char* TerminalConsole::help() {
  return "keys: s start, n next, r redo, k skip, p pause/resume, b mark the last take bad, t note, q abort";
}

TerminalConsole::TerminalConsole(Runner& runner) : runner_(runner) {
  termios t{};
  if (tcgetattr(STDIN_FILENO, &t) == 0) {
    std::memcpy(saved_termios_, &t, sizeof t);
    saved_ = true;
  }
  raw(true);
}

TerminalConsole::~TerminalConsole() { raw(false); }

void TerminalConsole::raw(bool on) {
  if (!saved_) return;
  termios t{};
  std::memcpy(&t, saved_termios_, sizeof t);
  if (on) {
    t.c_lflag &= ~tcflag_t(ICANON | ECHO);  // a key at a time, not echoed; Ctrl-C still stops (ISIG kept)
    t.c_cc[VMIN] = 1;
    t.c_cc[VTIME] = 0;
  }
  tcsetattr(STDIN_FILENO, TCSANOW, &t);
}

void TerminalConsole::run(const std::atomic<bool>& stop) {
  spdlog::info("operator: {}", help());
  while (!stop.load()) {
    pollfd p{STDIN_FILENO, POLLIN, 0};
    if (poll(&p, 1, 100) <= 0) continue;
    char key = 0;
    if (read(STDIN_FILENO, &key, 1) != 1) return;  // the terminal went away
    std::string argument;
    Command c;
    switch (key) {
      case 's':
        c = Command::Start;
        break;
      case 'n':
        c = Command::Next;
        break;
      case 'r':
        c = Command::Redo;
        break;
      case 'k':
        c = Command::Skip;
        break;
      case 'p':
        c = runner_.view().phase == Phase::Paused ? Command::Resume : Command::Pause;
        break;
      case 'b':
        c = Command::Bad;
        break;
      case 'q':
        c = Command::Abort;
        argument = "operator";
        break;
      case 't': {
        c = Command::Note;
        raw(false);
        std::cout << "note (Enter to save): " << std::flush;
        std::getline(std::cin, argument);
        raw(true);
        break;
      }
      case '?':
      case 'h':
        spdlog::info("operator: {}", help());
        continue;
      default:
        continue;
    }
    const auto reply = runner_.command(c, argument);
    if (reply.ok)
      spdlog::info("operator: {}", reply.message);
    else
      spdlog::warn("operator: refused: {}", reply.message);
  }
}

}  // namespace pvcap::console
