#include "storage/index/database.h"

#include <cstring>
#include <utility>

#include <sqlite3.h>

#include <fmt/format.h>

#include "storage/index/checked_vfs.h"

namespace pvcap::sqlite {

bool SqliteError::disk_full() const { return (code_ & 0xff) == SQLITE_FULL || (code_ & 0xff) == SQLITE_IOERR; }
bool SqliteError::io_failed() const { return (code_ & 0xff) == SQLITE_IOERR || (code_ & 0xff) == SQLITE_CORRUPT; }

namespace {
// SQLite says "disk I/O error"; the operating system's error (EIO, ENOSPC, EROFS) says which.
std::string os_error(sqlite3* db, int rc) {
  const int primary = rc & 0xff;
  // A read the disk failed with EIO, SQLite reports as a malformed file (SQLITE_IOERR_CORRUPTFS, passed
  // on as SQLITE_CORRUPT, with no errno kept): name both causes, or an operator looks only for damage.
  if (primary == SQLITE_CORRUPT) return ": the file is damaged, or the disk failed a read";
  if (!db ||
      (primary != SQLITE_IOERR && primary != SQLITE_FULL && primary != SQLITE_READONLY && primary != SQLITE_CANTOPEN))
    return "";
  // A sync that failed at a commit leaves SQLite no errno (and errno may have moved on since a
  // folder's): the checked VFS kept it.
  const int extended = sqlite3_extended_errcode(db);
  if (extended == SQLITE_IOERR_FSYNC || extended == SQLITE_IOERR_DIR_FSYNC) {
    if (const SyncFailure sync = take_sync_failure(); sync.error != 0)
      return sync.folder.empty() ? fmt::format(": fsync: {}", std::strerror(sync.error))
                                 : fmt::format(": fsync of the folder {}: {}", sync.folder, std::strerror(sync.error));
  }
  const int e = sqlite3_system_errno(db);
  std::string out = e ? fmt::format(": {}", std::strerror(e)) : "";
  // A read that failed may have been of the write-ahead log beside the index: SQLite does not say
  // which file, so while there is one, both are named.
  if (primary == SQLITE_IOERR && (extended == SQLITE_IOERR_READ || extended == SQLITE_IOERR_SHORT_READ)) {
    const char* file = sqlite3_db_filename(db, "main");
    std::error_code ec;
    if (file && *file && std::filesystem::exists(std::string(file) + "-wal", ec))
      out += fmt::format(" (reading {} or its write-ahead log {}-wal)", std::filesystem::path(file).filename().string(),
                         std::filesystem::path(file).filename().string());
  }
  return out;
}

[[noreturn]] void fail(sqlite3* db, int rc, std::string_view what) {
  const char* file = db ? sqlite3_db_filename(db, "main") : nullptr;
  throw SqliteError(rc, fmt::format("{}{}{}: {}{} (SQLite code {})", file ? file : "", file ? ": " : "", what,
                                    db ? sqlite3_errmsg(db) : sqlite3_errstr(rc), os_error(db, rc), rc));
}
}  // namespace

Statement::Statement(sqlite3* db, std::string_view sql) : db_(db) {
  const int rc = sqlite3_prepare_v2(db, sql.data(), int(sql.size()), &stmt_, nullptr);
  if (rc != SQLITE_OK) fail(db, rc, fmt::format("cannot prepare '{}'", sql.substr(0, 60)));
}
Statement::~Statement() {
  if (home_ && stmt_)
    home_->give_back(stmt_);
  else
    sqlite3_finalize(stmt_);
}
Statement::Statement(Statement&& o) noexcept : db_(o.db_), stmt_(o.stmt_), home_(o.home_) { o.stmt_ = nullptr; }

Statement& Statement::bind(int i, std::int64_t v) {
  if (int rc = sqlite3_bind_int64(stmt_, i, v); rc != SQLITE_OK) fail(db_, rc, "bind");
  return *this;
}
Statement& Statement::bind(int i, double v) {
  if (int rc = sqlite3_bind_double(stmt_, i, v); rc != SQLITE_OK) fail(db_, rc, "bind");
  return *this;
}
Statement& Statement::bind(int i, std::string_view v) {
  if (int rc = sqlite3_bind_text(stmt_, i, v.data(), int(v.size()), SQLITE_TRANSIENT); rc != SQLITE_OK)
    fail(db_, rc, "bind");
  return *this;
}
Statement& Statement::bind(int i, std::nullopt_t) {
  if (int rc = sqlite3_bind_null(stmt_, i); rc != SQLITE_OK) fail(db_, rc, "bind");
  return *this;
}

Statement& Statement::bind(int i, const std::vector<std::uint8_t>& blob) {
  if (int rc = sqlite3_bind_blob(stmt_, i, blob.data(), int(blob.size()), SQLITE_TRANSIENT); rc != SQLITE_OK)
    fail(db_, rc, "bind");
  return *this;
}

std::vector<std::uint8_t> Statement::column_blob(int c) const {
  const auto* p = static_cast<const std::uint8_t*>(sqlite3_column_blob(stmt_, c));
  return p ? std::vector<std::uint8_t>(p, p + sqlite3_column_bytes(stmt_, c)) : std::vector<std::uint8_t>{};
}

bool Statement::step() {
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  fail(db_, rc, "step");
}
void Statement::run() {
  while (step()) {
  }
  reset();
}
void Statement::reset() {
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
}
std::int64_t Statement::column_int(int c) const { return sqlite3_column_int64(stmt_, c); }
double Statement::column_double(int c) const { return sqlite3_column_double(stmt_, c); }
std::string Statement::column_text(int c) const {
  const auto* t = sqlite3_column_text(stmt_, c);
  return t ? std::string(reinterpret_cast<const char*>(t)) : std::string();
}
bool Statement::column_null(int c) const { return sqlite3_column_type(stmt_, c) == SQLITE_NULL; }

namespace {
// A path as an SQLite URI's file part: the characters a URI gives meaning to, escaped.
std::string uri_path(const std::filesystem::path& path) {
  std::string out;
  for (const char c : path.string()) {
    if (c == '%' || c == '?' || c == '#')
      out += fmt::format("%{:02X}", static_cast<unsigned char>(c));
    else
      out += c;
  }
  return out;
}
}  // namespace

Database::Database(const std::filesystem::path& path, Mode mode) : path_(path) {
  int flags = mode == Mode::ReadOnly ? SQLITE_OPEN_READONLY : SQLITE_OPEN_READWRITE;
  if (mode == Mode::Create) flags |= SQLITE_OPEN_CREATE;
  const auto open = [&](const std::string& name, int extra) {
    // The unix VFS with the folder syncs SQLite ignores checked (storage/index/checked_vfs.h).
    const int rc = sqlite3_open_v2(name.c_str(), &db_, flags | extra | SQLITE_OPEN_NOMUTEX, checked_vfs_name());
    if (rc != SQLITE_OK) {
      const std::string msg = db_ ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
      sqlite3_close(db_);
      db_ = nullptr;
      throw SqliteError(rc, fmt::format("{}: cannot open the session index: {}", path.string(), msg));
    }
    sqlite3_busy_timeout(db_, 2000);
  };
  open(path.string(), 0);
  if (mode != Mode::ReadOnly) return;
  // A store left in WAL mode is read through a shared-memory file beside it, which SQLite creates on
  // first read: on a read-only mount (a training node's dataset) it cannot, and the read fails. There
  // nothing can change the file under this reader, so it is opened as immutable: read as it lies,
  // without the shared-memory file or locks, and nothing is ever created beside it.
  sqlite3_stmt* probe = nullptr;
  int rc = sqlite3_prepare_v2(db_, "SELECT count(*) FROM sqlite_master", -1, &probe, nullptr);
  if (rc == SQLITE_OK) rc = sqlite3_step(probe);
  sqlite3_finalize(probe);
  const int primary = rc & 0xff;
  if (rc == SQLITE_ROW || rc == SQLITE_DONE || rc == SQLITE_OK) return;
  // Any other failure of this first read (a disk that fails it) is the reader's error, as it would be
  // at its own first query.
  if (primary != SQLITE_CANTOPEN && primary != SQLITE_READONLY) {
    // Thrown from the constructor: no destructor closes the connection, so it is closed here.
    try {
      fail(db_, rc, "cannot read the index");
    } catch (...) {
      sqlite3_close_v2(db_);
      db_ = nullptr;
      throw;
    }
  }
  sqlite3_close_v2(db_);
  db_ = nullptr;
  // Immutable ignores a write-ahead log: one that still holds commits must not be read past in silence.
  std::error_code ec;
  const auto wal = std::filesystem::path(path.string() + "-wal");
  if (const auto size = std::filesystem::file_size(wal, ec); !ec && size > 0)
    throw SqliteError(rc, fmt::format("{}: its write-ahead log ({}) holds commits not yet in the file, and this "
                                      "folder cannot be written to fold them in: open it once where it can be "
                                      "written (`pvcap recover` on the session folder)",
                                      path.string(), wal.filename().string()));
  open("file:" + uri_path(path) + "?immutable=1", SQLITE_OPEN_URI);
}

Database::~Database() {
  for (auto& [sql, idle] : cache_)
    for (sqlite3_stmt* s : idle) sqlite3_finalize(s);
  sqlite3_close_v2(db_);
}

Statement Database::cached(std::string_view sql) {
  if (auto it = cache_.find(std::string(sql)); it != cache_.end() && !it->second.empty()) {
    sqlite3_stmt* s = it->second.back();
    it->second.pop_back();
    return Statement(db_, s, this);
  }
  Statement fresh(db_, sql);
  sqlite3_stmt* s = std::exchange(fresh.stmt_, nullptr);
  return Statement(db_, s, this);
}

void Database::give_back(sqlite3_stmt* stmt) {
  // Reset: it holds no read transaction open while idle, and binds nothing stale.
  sqlite3_reset(stmt);
  sqlite3_clear_bindings(stmt);
  auto& idle = cache_[sqlite3_sql(stmt)];
  if (idle.size() < 4)
    idle.push_back(stmt);
  else
    sqlite3_finalize(stmt);
}

void Database::apply_resilient_pragmas() {
  exec("PRAGMA journal_mode=WAL");
  // FULL: each commit's WAL is fsynced, so a protocol transition acknowledged to the operator (it
  // waits for its commit) survives a power cut; commits come at most 4 a second while recording.
  exec("PRAGMA synchronous=FULL");
  exec("PRAGMA foreign_keys=ON");
}

void Database::exec(std::string_view sql) {
  char* err = nullptr;
  const std::string s(sql);
  const int rc = sqlite3_exec(db_, s.c_str(), nullptr, nullptr, &err);
  if (rc != SQLITE_OK) {
    const std::string msg = err ? err : sqlite3_errstr(rc);
    sqlite3_free(err);
    throw SqliteError(rc, fmt::format("{}: {}{} (in '{}')", path_.string(), msg, os_error(db_, rc), s.substr(0, 60)));
  }
}

int Database::user_version() {
  Statement st(db_, "PRAGMA user_version");
  return st.step() ? int(st.column_int(0)) : 0;
}
void Database::set_user_version(int v) { exec(fmt::format("PRAGMA user_version={}", v)); }
std::int64_t Database::last_insert_rowid() const { return sqlite3_last_insert_rowid(db_); }
std::int64_t Database::changes() const { return sqlite3_changes64(db_); }

void Database::define_function(const char* name, IntIntRealRealIntFunction fn) {
  auto call = [](sqlite3_context* ctx, int, sqlite3_value** v) {
    for (int i = 0; i < 5; ++i)
      if (sqlite3_value_type(v[i]) == SQLITE_NULL) return sqlite3_result_null(ctx);
    auto f = reinterpret_cast<IntIntRealRealIntFunction>(sqlite3_user_data(ctx));
    sqlite3_result_int64(ctx, f(sqlite3_value_int64(v[0]), sqlite3_value_int64(v[1]), sqlite3_value_double(v[2]),
                                sqlite3_value_double(v[3]), sqlite3_value_int64(v[4])));
  };
  const int rc = sqlite3_create_function_v2(db_, name, 5, SQLITE_UTF8 | SQLITE_DETERMINISTIC,
                                            reinterpret_cast<void*>(fn), call, nullptr, nullptr, nullptr);
  if (rc != SQLITE_OK)
    throw SqliteError(rc, fmt::format("{}: cannot define {}: {}", path_.string(), name, sqlite3_errstr(rc)));
}

}  // namespace pvcap::sqlite
