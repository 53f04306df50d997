#pragma once
// The dataset's catalogue (`catalog.db`): what `pvcap dataset` knows of every session folder under
// the dataset's roots, derived from the session stores and rebuilt from them at any time (a schema
// this pvcap does not write is dropped and rebuilt, never migrated). One row per session folder
// with the fingerprint that makes a rescan of an unchanged folder read nothing, and one row per
// take recorded in that folder. Schema: docs/dataset.md.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/result.h"

namespace pvcap {
namespace sqlite {
class Database;
}

struct CatalogSession {
  std::string folder;       // absolute
  std::string fingerprint;  // sizes and times of the index and videos when scanned
  std::string original;     // the first folder of a resumed chain (itself when not resumed)
  std::string participant, skin_tone, hand_order, lighting, overlay;
  // The lighting its takes' images showed (the rig's code, docs/lighting.md), most often among the takes
  // recorded under its label; "" where nothing measured it (a rig without lights).
  std::string lighting_seen;
  std::string protocol;  // the protocol's name as the session recorded it ("" without one)
  std::int64_t started_wall_ns = 0;
  int verify_exit = 0;     // pvcap verify's exit code: 0 clean, 3 lossy, 1 failed
  std::string facts_json;  // verify's losses and errors, losses by reason, self-check, calibration
};

struct CatalogTake {
  std::string folder;
  int step = 0;
  std::string sequence, action, hand, force, status;
  std::optional<bool> check_ok;
  std::string problems;  // what the take check found, one per line
  std::optional<std::int64_t> start_ns;
  std::string lighting_commanded, lighting_seen;  // "" without lights
};

class CatalogDb {
 public:
  // Opens (creating when missing) DIR/catalog.db for a scan; a catalogue of another version is
  // dropped and rebuilt. An unreadable file is an Error naming it.
  static Result<std::unique_ptr<CatalogDb>> open(const std::filesystem::path& file);
  // Opens it to read only (a reader, the Python module, a dataset on a read-only mount): nothing is
  // created or changed, and a catalogue of another version is an Error naming the command that
  // rebuilds it (`rebuild`, e.g. "pvcap dataset status DIR"), never an empty answer.
  static Result<std::unique_ptr<CatalogDb>> open_read_only(const std::filesystem::path& file,
                                                           const std::string& rebuild);
  ~CatalogDb();

  std::optional<std::string> fingerprint(const std::string& folder);
  // The session's row and its takes, replacing what was there, in one transaction.
  Status put(const CatalogSession& s, const std::vector<CatalogTake>& takes);
  // Forgets folders no longer found (or withdrawn); returns how many.
  Result<std::size_t> remove_except(const std::vector<std::string>& folders);
  std::vector<CatalogSession> sessions();  // by participant, then start
  std::vector<CatalogTake> takes();        // by folder, then step and start

 private:
  explicit CatalogDb(std::unique_ptr<sqlite::Database> db);
  std::unique_ptr<sqlite::Database> db_;
};

}  // namespace pvcap
