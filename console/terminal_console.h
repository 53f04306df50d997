#pragma once
// The operator's keyboard on the terminal pvcap runs in (works over SSH): one key
// a command, each acknowledged or refused with why. Keys:
//   s start   n next   r redo   k skip   p pause/resume   b bad   t note   q abort
#include <atomic>

#include "protocol/runner.h"

namespace pvcap::console {

class TerminalConsole {
 public:
  // True when stdin is a terminal (otherwise there is no keyboard to read).
  static bool available();
  explicit TerminalConsole(protocol::Runner& runner);
  ~TerminalConsole();  // the terminal's settings restored
  TerminalConsole(const TerminalConsole&) = delete;
  TerminalConsole& operator=(const TerminalConsole&) = delete;

  // Reads keys until `stop`; returns then (polls every 100 ms).
  void run(const std::atomic<bool>& stop);
  static const char* help();

 private:
  void raw(bool on);
  protocol::Runner& runner_;
  bool saved_ = false;
  unsigned char saved_termios_[64] = {};  // struct termios, kept opaque here
};

}  // namespace pvcap::console
