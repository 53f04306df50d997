#pragma once
// The SQLite edge: a connection and prepared statements as RAII types with
// typed binding, and errors that carry SQLite's code and the database's path.
// Storage code runs on writer threads (never a capture thread), so failures
// are thrown as SqliteError and turned into one message at the writer's edge.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

struct sqlite3;
struct sqlite3_stmt;

namespace pvcap::sqlite {

class SqliteError : public std::runtime_error {
 public:
  SqliteError(int code, const std::string& message) : std::runtime_error(message), code_(code) {}
  int code() const { return code_; }
  bool disk_full() const;
  // The file could not be read or written as it is on disk: an I/O error, or what SQLite reports for a
  // read the disk failed with EIO (SQLITE_IOERR_CORRUPTFS, passed on as SQLITE_CORRUPT). A reader that
  // skips a damaged frame never skips this: its command fails naming the file.
  bool io_failed() const;

 private:
  int code_;
};

class Database;

class Statement {
 public:
  Statement(sqlite3* db, std::string_view sql);
  ~Statement();
  Statement(Statement&&) noexcept;
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  Statement& bind(int index, std::int64_t v);
  Statement& bind(int index, int v) { return bind(index, std::int64_t(v)); }
  Statement& bind(int index, std::uint64_t v) { return bind(index, std::int64_t(v)); }
  Statement& bind(int index, double v);
  Statement& bind(int index, std::string_view v);
  Statement& bind(int index, const char* v) { return bind(index, std::string_view(v)); }
  Statement& bind(int index, std::nullopt_t);
  Statement& bind(int index, const std::vector<std::uint8_t>& blob);
  template <typename T>
  Statement& bind(int index, const std::optional<T>& v) {
    return v ? bind(index, *v) : bind(index, std::nullopt);
  }
  // Binds all arguments in order, starting at 1.
  template <typename... Args>
  Statement& bind_all(const Args&... args) {
    int i = 0;
    (bind(++i, args), ...);
    return *this;
  }

  bool step();  // true while a row is available
  void run();   // step to completion and reset (for INSERT/UPDATE)
  void reset();

  std::int64_t column_int(int col) const;
  double column_double(int col) const;
  std::string column_text(int col) const;
  bool column_null(int col) const;
  std::vector<std::uint8_t> column_blob(int col) const;

 private:
  friend class Database;
  Statement(sqlite3* db, sqlite3_stmt* stmt, Database* home) : db_(db), stmt_(stmt), home_(home) {}
  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
  Database* home_ = nullptr;  // cached(): handed back to this database's cache, not finalized
};

class Database {
 public:
  enum class Mode { ReadOnly, ReadWrite, Create };
  Database(const std::filesystem::path& path, Mode mode);
  ~Database();
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;

  // "Resilient" preset for recording: WAL (readers never block the writer, a crash
  // loses at most the open transaction) with synchronous=NORMAL.
  void apply_resilient_pragmas();
  void exec(std::string_view sql);
  Statement prepare(std::string_view sql) { return Statement(db_, sql); }
  // The same, prepared once per connection and kept for the next call with the same SQL: for
  // queries run per sample or per frame, where preparing costs as much as the query. Handed back
  // reset when the Statement is destroyed. Like the connection itself, for one thread at a time.
  Statement cached(std::string_view sql);
  int user_version();
  void set_user_version(int v);
  std::int64_t last_insert_rowid() const;
  std::int64_t changes() const;  // rows changed by the last statement
  // Makes `name(int, int, real, real, int) -> int` callable in this connection's SQL (NULL in, NULL
  // out): how a C++ rule, such as the clock model's mapping, is applied by one UPDATE.
  using IntIntRealRealIntFunction = std::int64_t (*)(std::int64_t, std::int64_t, double, double, std::int64_t);
  void define_function(const char* name, IntIntRealRealIntFunction fn);
  const std::filesystem::path& path() const { return path_; }

 private:
  friend class Statement;
  void give_back(sqlite3_stmt* stmt);
  sqlite3* db_ = nullptr;
  std::filesystem::path path_;
  std::unordered_map<std::string, std::vector<sqlite3_stmt*>> cache_;  // idle statements by their SQL
};

// Holds one transaction; commits on commit(), rolls back when destroyed without it.
class Transaction {
 public:
  explicit Transaction(Database& db) : db_(db) { db_.exec("BEGIN IMMEDIATE"); }
  ~Transaction() {
    if (!done_) try {
        db_.exec("ROLLBACK");
      } catch (...) {
      }
  }
  void rollback() {
    if (!done_) db_.exec("ROLLBACK");
    done_ = true;
  }
  void commit() {
    db_.exec("COMMIT");
    done_ = true;
  }

 private:
  Database& db_;
  bool done_ = false;
};

}  // namespace pvcap::sqlite
