#pragma once
// Logging: one console sink for the operator (set up once by the app) and a file
// sink added per session directory, both on spdlog's default logger.
#include <filesystem>
#include <string>

namespace pvcap::log {

// Console logger at `level` ("trace".."off"); also routes Aravis/GLib warnings into it.
void init_console(const std::string& level);

// Adds `<dir>/pvcap.log` (debug level) to the default logger; returns its path.
std::filesystem::path add_session_file(const std::filesystem::path& dir);

// Removes the session file sink (flushes it first).
void remove_session_file();

}  // namespace pvcap::log
