#pragma once
// Puts a SenselEmulator behind a pseudo-terminal, like a Morph behind
// /dev/ttyACM0: the driver opens slave_path() with its tty transport. Frames are
// paced like the device: 8 ms per scan at medium detail; at high detail 19.6 ms
// plus 12.5 us per payload byte (the spec's measured floor and slope, §9). Answers
// reach the host after a random USB delay, and a test can make the device stall
// or vanish.
#include <atomic>
#include <mutex>
#include <string>
#include <thread>

#include "core/result.h"
#include "sim/sensel_emulator.h"

namespace pvcap::sim {

struct SenselLink {
  double jitter_mean_ms = 0;  // USB arrival delay after the scan: exponential with this mean...
  double jitter_max_ms = 0;   // ...capped here (a long tail, not an unbounded one)
  std::uint64_t seed = 1;
};

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
