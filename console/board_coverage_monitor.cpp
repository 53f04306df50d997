#include "console/board_coverage_monitor.h"

#include <chrono>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include "calib/charuco.h"
#include "session/recording.h"

namespace pvcap::console {

BoardCoverageMonitor::BoardCoverageMonitor(const session::Recording& recording) : recording_(recording) {
  for (const CameraConfig& c : recording_.rig().cameras)
    coverage_.emplace_back(cv::Size(c.width, c.height), calib::BoardSpec{});
  said_covered_.assign(coverage_.size(), false);
  thread_ = std::thread([this] { run(); });
}

BoardCoverageMonitor::~BoardCoverageMonitor() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
}

std::vector<std::string> BoardCoverageMonitor::summary() const {
  const std::lock_guard lock(mu_);
  std::vector<std::string> out;
  for (std::size_t c = 0; c < coverage_.size(); ++c)
    out.push_back(fmt::format("{}: {}", recording_.rig().cameras[c].name, coverage_[c].summary()));
  return out;
}

void BoardCoverageMonitor::run() {
  const calib::BoardSpec spec;
  std::vector<std::int64_t> seen(coverage_.size(), 0);  // each camera's newest preview searched
  auto next_report = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (!stop_.load()) {
    for (std::size_t c = 0; c < coverage_.size() && !stop_.load(); ++c) {
      auto [frame, at_ns] = recording_.preview_full(c, seen[c]);  // copied only when new
      if (frame.empty()) continue;
      seen[c] = at_ns;
      const calib::BoardView view = calib::detect_board_coarse(frame, spec);
      const std::lock_guard lock(mu_);
      coverage_[c].add(view);
      if (!said_covered_[c] && coverage_[c].missing().empty()) {
        said_covered_[c] = true;
        spdlog::info("board: {} covered ({} views): its lens can be fitted", recording_.rig().cameras[c].name,
                     coverage_[c].views());
      }
    }
    if (std::chrono::steady_clock::now() >= next_report) {
      next_report += std::chrono::seconds(5);
      for (const std::string& line : summary())
        if (line.find(": covered") == std::string::npos) spdlog::info("board: {}", line);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
}

}  // namespace pvcap::console
