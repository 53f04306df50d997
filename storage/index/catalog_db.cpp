#include "storage/index/catalog_db.h"

#include <fmt/format.h>

#include "storage/index/database.h"

namespace pvcap {

namespace {

constexpr int kCatalogVersion = 2;  // 2: the lighting the images saw

constexpr const char* kSchema = R"sql(
CREATE TABLE sessions (
  folder TEXT PRIMARY KEY,
  fingerprint TEXT NOT NULL,
  original TEXT NOT NULL,
  participant TEXT NOT NULL,
  skin_tone TEXT NOT NULL,
  hand_order TEXT NOT NULL,
  lighting TEXT NOT NULL,
  lighting_seen TEXT NOT NULL,
  overlay TEXT NOT NULL,
  protocol TEXT NOT NULL,
  started_wall_ns INTEGER NOT NULL,
  verify_exit INTEGER NOT NULL,
  facts_json TEXT NOT NULL
);
CREATE TABLE takes (
  folder TEXT NOT NULL REFERENCES sessions(folder) ON DELETE CASCADE,
  step INTEGER NOT NULL,
  sequence TEXT NOT NULL,
  action TEXT NOT NULL,
  hand TEXT NOT NULL,
  force TEXT NOT NULL,
  status TEXT NOT NULL,
  check_ok INTEGER,
  problems TEXT NOT NULL,
  start_ns INTEGER,
  lighting_commanded TEXT NOT NULL,
  lighting_seen TEXT NOT NULL
);
CREATE INDEX takes_by_folder ON takes(folder);
)sql";

}  // namespace

CatalogDb::CatalogDb(std::unique_ptr<sqlite::Database> db) : db_(std::move(db)) {}
CatalogDb::~CatalogDb() = default;

Result<std::unique_ptr<CatalogDb>> CatalogDb::open(const std::filesystem::path& file) {
  try {
    auto db = std::make_unique<sqlite::Database>(file, sqlite::Database::Mode::Create);
    db->exec("PRAGMA foreign_keys = ON");
    if (db->user_version() != kCatalogVersion) {
      // Derived data: another version's catalogue is dropped and rebuilt by the next scan.
      db->exec("DROP TABLE IF EXISTS takes; DROP TABLE IF EXISTS sessions;");
      db->exec(kSchema);
      db->set_user_version(kCatalogVersion);
    }
    return std::unique_ptr<CatalogDb>(new CatalogDb(std::move(db)));
  } catch (const sqlite::SqliteError& e) {
    return Error{
        fmt::format("{}: the dataset's catalogue cannot be opened ({}); it is derived from the sessions: "
                    "remove it and scan again",
                    file.string(), e.what())};
  }
}

Result<std::unique_ptr<CatalogDb>> CatalogDb::open_read_only(const std::filesystem::path& file,
                                                             const std::string& rebuild) {
  try {
    auto db = std::make_unique<sqlite::Database>(file, sqlite::Database::Mode::ReadOnly);
    if (const int version = db->user_version(); version != kCatalogVersion)
      return Error{
          fmt::format("{}: a catalogue of version {}, and this pvcap reads version {}: `{}` rebuilds it "
                      "from the sessions",
                      file.string(), version, kCatalogVersion, rebuild)};
    return std::unique_ptr<CatalogDb>(new CatalogDb(std::move(db)));
  } catch (const sqlite::SqliteError& e) {
    return Error{fmt::format("{}: the dataset's catalogue cannot be read ({}); `{}` rebuilds it from the sessions",
                             file.string(), e.what(), rebuild)};
  }
}

std::optional<std::string> CatalogDb::fingerprint(const std::string& folder) {
  auto q = db_->prepare("SELECT fingerprint FROM sessions WHERE folder = ?");
  q.bind(1, folder);
  if (!q.step()) return std::nullopt;
  return q.column_text(0);
}

Status CatalogDb::put(const CatalogSession& s, const std::vector<CatalogTake>& takes) {
  try {
    sqlite::Transaction tx(*db_);
    db_->prepare("DELETE FROM sessions WHERE folder = ?").bind(1, s.folder).run();
    db_->prepare(
           "INSERT INTO sessions (folder, fingerprint, original, participant, skin_tone, hand_order, lighting, "
           "overlay, protocol, started_wall_ns, verify_exit, facts_json, lighting_seen) VALUES "
           "(?,?,?,?,?,?,?,?,?,?,?,?,?)")
        .bind_all(s.folder, s.fingerprint, s.original, s.participant, s.skin_tone, s.hand_order, s.lighting, s.overlay,
                  s.protocol, s.started_wall_ns, s.verify_exit, s.facts_json, s.lighting_seen)
        .run();
    auto insert = db_->prepare(
        "INSERT INTO takes (folder, step, sequence, action, hand, force, status, check_ok, problems, start_ns, "
        "lighting_commanded, lighting_seen) VALUES (?,?,?,?,?,?,?,?,?,?,?,?)");
    for (const auto& t : takes) {
      insert.bind_all(s.folder, t.step, t.sequence, t.action, t.hand, t.force, t.status, std::nullopt, t.problems,
                      t.start_ns, t.lighting_commanded, t.lighting_seen);
      if (t.check_ok) insert.bind(8, std::int64_t(*t.check_ok ? 1 : 0));
      insert.run();
    }
    tx.commit();
    return {};
  } catch (const sqlite::SqliteError& e) {
    return Error{fmt::format("{}: cannot record {}: {}", db_->path().string(), s.folder, e.what())};
  }
}

Result<std::size_t> CatalogDb::remove_except(const std::vector<std::string>& folders) {
  try {
    sqlite::Transaction tx(*db_);
    db_->exec("CREATE TEMP TABLE IF NOT EXISTS keep (folder TEXT PRIMARY KEY); DELETE FROM keep;");
    auto insert = db_->prepare("INSERT OR IGNORE INTO keep (folder) VALUES (?)");
    for (const auto& f : folders) insert.bind(1, f).run();
    db_->exec("DELETE FROM sessions WHERE folder NOT IN (SELECT folder FROM keep)");
    const auto removed = std::size_t(db_->changes());
    tx.commit();
    return removed;
  } catch (const sqlite::SqliteError& e) {
    return Error{fmt::format("{}: cannot forget the folders no longer found: {}", db_->path().string(), e.what())};
  }
}

std::vector<CatalogSession> CatalogDb::sessions() {
  std::vector<CatalogSession> out;
  auto q = db_->prepare(
      "SELECT folder, fingerprint, original, participant, skin_tone, hand_order, lighting, overlay, protocol, "
      "started_wall_ns, verify_exit, facts_json, lighting_seen FROM sessions ORDER BY participant, started_wall_ns, "
      "folder");
  while (q.step()) {
    CatalogSession s;
    s.folder = q.column_text(0);
    s.fingerprint = q.column_text(1);
    s.original = q.column_text(2);
    s.participant = q.column_text(3);
    s.skin_tone = q.column_text(4);
    s.hand_order = q.column_text(5);
    s.lighting = q.column_text(6);
    s.overlay = q.column_text(7);
    s.protocol = q.column_text(8);
    s.started_wall_ns = q.column_int(9);
    s.verify_exit = int(q.column_int(10));
    s.facts_json = q.column_text(11);
    s.lighting_seen = q.column_text(12);
    out.push_back(std::move(s));
  }
  return out;
}

std::vector<CatalogTake> CatalogDb::takes() {
  std::vector<CatalogTake> out;
  auto q = db_->prepare(
      "SELECT folder, step, sequence, action, hand, force, status, check_ok, problems, start_ns, lighting_commanded, "
      "lighting_seen FROM takes ORDER BY folder, step, start_ns");
  while (q.step()) {
    CatalogTake t;
    t.folder = q.column_text(0);
    t.step = int(q.column_int(1));
    t.sequence = q.column_text(2);
    t.action = q.column_text(3);
    t.hand = q.column_text(4);
    t.force = q.column_text(5);
    t.status = q.column_text(6);
    if (!q.column_null(7)) t.check_ok = q.column_int(7) != 0;
    t.problems = q.column_text(8);
    if (!q.column_null(9)) t.start_ns = q.column_int(9);
    t.lighting_commanded = q.column_text(10);
    t.lighting_seen = q.column_text(11);
    out.push_back(std::move(t));
  }
  return out;
}

}  // namespace pvcap
