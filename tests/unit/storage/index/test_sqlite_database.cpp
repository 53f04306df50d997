// The SQLite edge's statement cache (storage/index/database.h): a cached statement comes back
// reset with no stale bindings, two live uses of one SQL text do not share a statement, and the
// connection closes with statements still cached.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>

#include "storage/index/database.h"

namespace fs = std::filesystem;
using pvcap::sqlite::Database;

namespace {
struct TempDb {
  fs::path path = fs::temp_directory_path() / ("pvcap-test-sqlite-" + std::to_string(::getpid()) + ".db");
  ~TempDb() {
    std::error_code ec;
    fs::remove(path, ec);
  }
};
}  // namespace

TEST(SqliteDatabase, ACachedStatementComesBackResetWithItsBindingsCleared) {
  TempDb file;
  Database db(file.path, Database::Mode::Create);
  db.exec("CREATE TABLE t (k INTEGER PRIMARY KEY, v TEXT)");
  db.exec("INSERT INTO t VALUES (1, 'one'), (2, 'two'), (3, 'three')");
  const char* sql = "SELECT v FROM t WHERE k = ? OR ? IS NULL ORDER BY k";
  {
    auto q = db.cached(sql);
    q.bind_all(std::int64_t(2), std::int64_t(0));
    ASSERT_TRUE(q.step());
    EXPECT_EQ(q.column_text(0), "two");
    // Left mid-result: handed back reset.
  }
  {
    auto q = db.cached(sql);  // the same statement again: unbound, the first parameter is NULL
    q.bind(2, std::nullopt);
    int rows = 0;
    while (q.step()) ++rows;
    EXPECT_EQ(rows, 3) << "both parameters NULL: every row (a stale k = 2 would give none)";
  }
  {
    auto a = db.cached(sql), b = db.cached(sql);  // both live at once: two statements
    a.bind_all(std::int64_t(1), std::int64_t(0));
    b.bind_all(std::int64_t(3), std::int64_t(0));
    ASSERT_TRUE(a.step());
    ASSERT_TRUE(b.step());
    EXPECT_EQ(a.column_text(0), "one");
    EXPECT_EQ(b.column_text(0), "three");
  }
  // An idle cached statement holds no read transaction: a writer on another connection commits.
  {
    auto q = db.cached(sql);
    q.bind_all(std::int64_t(1), std::int64_t(0));
    ASSERT_TRUE(q.step());
  }
  Database other(file.path, Database::Mode::ReadWrite);
  other.exec("BEGIN EXCLUSIVE");
  other.exec("INSERT INTO t VALUES (4, 'four')");
  other.exec("COMMIT");
  auto q = db.cached(sql);
  q.bind_all(std::int64_t(4), std::int64_t(0));
  ASSERT_TRUE(q.step());
  EXPECT_EQ(q.column_text(0), "four");
}
