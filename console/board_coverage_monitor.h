#pragma once
// The board session's live feedback (`pvcap session --board`): each camera's latest whole frame
// (the preview, about every 0.7 s) searched for the board on a thread of its own, never a capture
// thread, and its views added to that camera's calib::BoardCoverage: the rule `pvcap calibrate
// intrinsics` tells its result by, so that a camera the operator sees "covered" gets a lens. Every
// 5 s one short line per camera not yet covered says where it is short (the first few places); the
// first time a camera is covered, a line says so; at the end, one line per camera.
#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "calib/board_coverage.h"

namespace pvcap::session {
class Recording;
}

namespace pvcap::console {

class BoardCoverageMonitor {
 public:
  explicit BoardCoverageMonitor(const session::Recording& recording);
  ~BoardCoverageMonitor();  // stops its thread
  BoardCoverageMonitor(const BoardCoverageMonitor&) = delete;
  BoardCoverageMonitor& operator=(const BoardCoverageMonitor&) = delete;

  // One line per camera: "cam0: covered (41 views)" or "cam1: 12 views; regions 10 of 12 (short:
  // ...); tilts 3 of 4 (short: ...)" (calib::BoardCoverage::summary).
  std::vector<std::string> summary() const;

 private:
  void run();

  const session::Recording& recording_;
  mutable std::mutex mu_;
  std::vector<calib::BoardCoverage> coverage_;
  std::vector<bool> said_covered_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace pvcap::console
