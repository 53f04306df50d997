#pragma once
// Debian's Chromium, headless, driven over the DevTools protocol on a pipe
// (--remote-debugging-pipe: NUL-terminated JSON messages on fds 3 and 4), so a
// test can keep a page open while the session pushes to it and read its DOM at
// any moment. No WebSocket client needed.
#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace pvcap::testing {

class HeadlessBrowser {
 public:
  // Starts Chromium with a fresh user-data dir; false from ok() when it is not installed.
  HeadlessBrowser(int width = 1280, int height = 720);
  ~HeadlessBrowser();
  HeadlessBrowser(const HeadlessBrowser&) = delete;
  HeadlessBrowser& operator=(const HeadlessBrowser&) = delete;
  bool ok() const { return pid_ > 0 && !failed_; }

  // Opens `url` in a new tab; returns the tab's session id ("" on failure).
  std::string open(const std::string& url);
  // Evaluates a JavaScript expression in the tab and returns its value (null on failure).
  nlohmann::json eval(const std::string& tab, const std::string& expression);
  std::string dom(const std::string& tab) { return eval(tab, "document.documentElement.outerHTML").get<std::string>(); }
  bool screenshot(const std::string& tab, const std::filesystem::path& png);
  // Uncaught exceptions and console.error() calls of the pages so far.
  const std::vector<std::string>& errors() const { return errors_; }

 private:
  nlohmann::json call(const std::string& method, const nlohmann::json& params, const std::string& session = {});
  bool send(const nlohmann::json& message);
  std::optional<nlohmann::json> receive(std::chrono::milliseconds timeout);

  pid_t pid_ = -1;
  int to_browser_ = -1, from_browser_ = -1;
  int next_id_ = 1;
  bool failed_ = false;
  std::string buffer_;
  std::filesystem::path profile_;
  std::vector<std::string> errors_;
};

}  // namespace pvcap::testing
