#pragma once
// What the two halves of the session reader share (storage/index/session_reader.cpp, the index;
// session_reader_images.cpp, the pictures from the videos). Not for other files.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include <fmt/format.h>

#include "core/result.h"
#include "storage/index/database.h"

namespace pvcap::session_reader_detail {

// Everything below turns SQLite's exceptions into an Error naming the store (marked disk_failed when
// the index could not be read as it is on disk: core/result.h).
template <typename F>
auto guarded(const std::filesystem::path& dir, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const sqlite::SqliteError& e) {
    return Error{fmt::format("{}: {}", dir.string(), e.what()), e.io_failed()};
  } catch (const std::exception& e) {
    return Error{fmt::format("{}: {}", dir.string(), e.what())};
  }
}

inline std::string text_or_empty(const sqlite::Statement& q, int col) {
  return q.column_null(col) ? "" : q.column_text(col);
}
inline std::optional<std::int64_t> opt_int(const sqlite::Statement& q, int col) {
  return q.column_null(col) ? std::nullopt : std::optional<std::int64_t>(q.column_int(col));
}

}  // namespace pvcap::session_reader_detail
