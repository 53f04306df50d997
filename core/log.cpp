#include "core/log.h"

#include <atomic>
#include <cstdio>

#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

namespace pvcap::log {

namespace {
std::shared_ptr<spdlog::sinks::basic_file_sink_mt> g_file_sink;

// Logging that fails (the session's log file on a disk that filled, failed or turned read-only)
// never ends a session: the console keeps the log, and the operator is told once.
void logging_failed(const std::string& what) {
  static std::atomic<bool> told{false};
  if (!told.exchange(true))
    std::fprintf(stderr, "[pvcap] the session's log file cannot be written (%s); the console keeps the log\n",
                 what.c_str());
}
}  // namespace

void init_console(const std::string& level) {
  auto console = std::make_shared<spdlog::sinks::stderr_color_sink_mt>();
  console->set_pattern("%^[%H:%M:%S.%e %l]%$ %v");
  console->set_level(spdlog::level::from_str(level));
  auto logger = std::make_shared<spdlog::logger>("pvcap", console);
  logger->set_level(spdlog::level::debug);
  logger->flush_on(spdlog::level::warn);
  spdlog::set_default_logger(logger);
}

std::filesystem::path add_session_file(const std::filesystem::path& dir) {
  const auto path = dir / "pvcap.log";
  g_file_sink = std::make_shared<spdlog::sinks::basic_file_sink_mt>(path.string());
  g_file_sink->set_pattern("[%Y-%m-%dT%H:%M:%S.%f %l t%t] %v");
  g_file_sink->set_level(spdlog::level::debug);
  spdlog::default_logger()->sinks().push_back(g_file_sink);
  spdlog::default_logger()->set_error_handler(logging_failed);
  spdlog::flush_every(std::chrono::seconds(1));
  return path;
}

void remove_session_file() {
  if (!g_file_sink) return;
  try {
    g_file_sink->flush();
  } catch (const std::exception& e) {
    logging_failed(e.what());
  }
  auto& sinks = spdlog::default_logger()->sinks();
  std::erase(sinks, std::static_pointer_cast<spdlog::sinks::sink>(g_file_sink));
  g_file_sink.reset();
}

}  // namespace pvcap::log
