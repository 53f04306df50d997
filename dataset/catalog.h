#pragma once
// The scan that keeps the dataset's catalogue (catalog.db) in step with its session folders: every
// folder holding a session.db under the dataset's roots is read (its participant and conditions,
// `pvcap verify`'s verdict, the report's losses, sync self-check and calibration, the takes it
// recorded) and recorded; a folder whose index and videos have not changed since the last scan is
// not read again (its fingerprint: their names, sizes and modification times); a folder no longer
// found, or a withdrawn participant's, is forgotten. The sessions are opened read-only.
#include <atomic>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "core/result.h"
#include "dataset/dataset_folder.h"
#include "storage/index/catalog_db.h"

namespace pvcap::dataset {

struct ScanResult {
  std::size_t found = 0, read = 0, unchanged = 0, forgotten = 0, withdrawn = 0;
  std::vector<std::string> problems;  // folders that could not be read (catalogued as failed), each with why
  double seconds = 0;
  // "catalogue: 3 session folders (1 read, 2 unchanged) in 0.4 s", as the scan's command logs it.
  std::string summary() const;
};

// Called before each folder is read (done of total) with its name, and while a folder is read with
// its name and what the reading is at (verify's file, the report's step).
using ScanProgress = std::function<void(std::size_t done, std::size_t total, const std::string& folder)>;

// The session folders under the roots (a folder holding session.db, at most two levels down;
// dot-folders skipped), sorted.
std::vector<std::filesystem::path> find_sessions(const std::vector<std::filesystem::path>& roots);
// What changes when a session's data change: the index, its WAL and the videos' names, sizes, times.
std::string session_fingerprint(const std::filesystem::path& folder);

Result<ScanResult> scan(const DatasetConfig& c, CatalogDb& db, const ScanProgress& progress,
                        const std::atomic<bool>& stop);

// Reads one session folder into its catalogue rows (what scan does for a changed folder); `step`,
// when given, is told what it is at (from two threads, never at once).
Result<std::pair<CatalogSession, std::vector<CatalogTake>>> read_session(
    const std::filesystem::path& folder, const std::function<void(const std::string&)>& step = nullptr);

}  // namespace pvcap::dataset
