#pragma once
// Puts a SenselEmulator behind a pseudo-terminal, like a Morph behind
// /dev/ttyACM0: the driver opens slave_path() with its tty transport. Answers are
// paced like the device's (sensel_pacing.h) and go out in 64-byte pieces; a test
// can make the device stall or vanish.
#include <atomic>
#include <mutex>
#include <string>
#include <thread>

#include "core/result.h"
#include "sim/sensel_emulator.h"
#include "sim/sensel_pacing.h"

namespace pvcap::sim {

class SenselPty {
 public:
  static Result<std::unique_ptr<SenselPty>> create(SenselEmulator& emulator, SenselLink link = {});
  ~SenselPty();

  const std::string& slave_path() const { return slave_path_; }
  // Answers nothing for `ms` (a hung device or a stuck USB link).
  void stall_for(int ms) { stall_ms_.store(ms); }
  // The device is gone: the terminal hangs up.
  void unplug();

 private:
  SenselPty(SenselEmulator& emu, SenselLink link) : emu_(emu), link_(link) {}
  void serve();

  SenselEmulator& emu_;
  SenselLink link_;
  int master_ = -1;
  std::string slave_path_;
  std::atomic<bool> running_{true};
  std::atomic<int> stall_ms_{0};
  std::thread thread_;
};

}  // namespace pvcap::sim
