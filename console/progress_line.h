#pragma once
// Progress of a long command (export, replay): one line rewritten in place on a terminal; a line
// per tenth of the work in a log (a cluster job's output), where rewriting would pile up.
#include <unistd.h>

#include <chrono>
#include <cstddef>
#include <cstdio>
#include <string>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace pvcap::console {

class ProgressLine {
 public:
  ProgressLine() : terminal_(isatty(STDERR_FILENO) == 1) {}
  void show(const std::string& line, std::size_t done, std::size_t total) {
    if (terminal_) {
      fmt::print(stderr, "\r{}\x1b[K{}", line, done >= total ? "\n" : "");
      std::fflush(stderr);
    } else if (const int decile = total ? int(10 * done / total) : 10; decile != last_decile_) {
      last_decile_ = decile;
      spdlog::info("{}", line);
    }
  }
  // A progress callback (done, total, the item at hand) that shows "<what>: done/total <unit>, N s<, item>",
  // N the seconds since the call; `item` formats the item's name ("" shows none).
  auto counter(std::string what, std::string unit, std::string (*item)(const std::string&)) {
    const auto started = std::chrono::steady_clock::now();
    return [this, what = std::move(what), unit = std::move(unit), item, started](std::size_t done, std::size_t total,
                                                                                 const std::string& name) {
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      show(fmt::format("{}: {}/{} {}, {:.0f} s{}", what, done, total, unit, s, name.empty() ? "" : item(name)), done,
           total);
    };
  }
  // Ends a line left open on a terminal (the work stopped early), so what follows starts clean.
  void abandon() {
    if (terminal_) fmt::print(stderr, "\n");
  }

 private:
  bool terminal_;
  int last_decile_ = -1;
};

}  // namespace pvcap::console
