#pragma once
// `pvcap dataset release`: the dataset's sessions exported in a released layout (export/), one
// independent job per session folder, plus what makes the folder a release: the splits, a datasheet
// (README.md), Croissant metadata (croissant.json) and SHA256SUMS over every file, which
// `sha256sum -c SHA256SUMS` checks.
//
// A release runs in three steps, so that a scheduler can run the middle one as a job array:
//   prepare  the plan (plan.json: which session folders, in which layout) and OUT/participants.json
//            (participant ids fixed in code order, so any order of jobs gives the same folders);
//   job i    (with --compact: compacts session i's raw video first, storage/tools/compact.h) exports
//            session i, then marks it done (done/i); a done job is skipped, an interrupted one
//            resumes where it stopped (the export keeps whole files, compact whole segments);
//   finish   once every job is done: splits.json, README.md, croissant.json, SHA256SUMS, and the
//            release recorded in the dataset's releases.json.
// The plan, the done markers and a scheduler's scripts and logs are kept in the dataset folder
// (DIR/releases/<the release folder's path>-<hash>/), never in the release, which holds only what the
// layout and the release's own files name.
#include <atomic>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "core/result.h"
#include "dataset/completeness.h"
#include "dataset/dataset_folder.h"
#include "dataset/splits.h"
#include "storage/index/catalog_db.h"

namespace pvcap::dataset {

struct ReleasePlan {
  std::filesystem::path out;              // absolute
  std::filesystem::path book;             // its bookkeeping folder in the dataset
  std::string layout;                     // pressurevision | pressurevision-plus
  bool compact = false;                   // each job compacts its session's raw video before exporting
  std::vector<std::string> sessions;      // folders, in participant then time order
  std::vector<std::string> participants;  // codes, sorted
  // Each session's done takes' sequence folders ("<step>:<start_ns>" -> folder), named in session
  // order per participant before any job runs: a participant's second take of one name is "(2)"
  // whichever job runs first.
  std::map<std::string, std::map<std::string, std::string>> sequence_folders;
};

// The dataset's folder holding a release's plan and done markers.
std::filesystem::path bookkeeping(const std::filesystem::path& dataset_dir, const std::filesystem::path& out);

Result<ReleasePlan> prepare_release(const std::filesystem::path& dataset_dir,
                                    const std::vector<CatalogSession>& sessions, const std::vector<CatalogTake>& takes,
                                    const std::vector<Withdrawal>& withdrawals, const std::filesystem::path& out,
                                    const std::string& layout, bool compact = false);
Result<ReleasePlan> load_plan(const std::filesystem::path& dataset_dir, const std::filesystem::path& out);
bool job_done(const ReleasePlan& plan, std::size_t index);
std::vector<std::size_t> pending_jobs(const ReleasePlan& plan);

// Exports session `index` of the plan (skipping it when done), compacting it first when the plan says so.
Status run_release_job(const ReleasePlan& plan, std::size_t index, const std::atomic<bool>& stop);

// Every pending job on `workers` threads of this machine; progress is (jobs done, total, folder).
Status run_local(const ReleasePlan& plan, int workers,
                 const std::function<void(std::size_t, std::size_t, const std::string&)>& progress,
                 const std::atomic<bool>& stop);

struct ReleaseSummary {
  std::size_t files = 0, sequences = 0, frames = 0;
  std::uintmax_t bytes = 0;
};

// What a release needs from dataset.yaml before a single session is exported (its Croissant metadata
// requires a licence, a URL and creators): an Error naming the file and each missing key.
Status check_release_metadata(const DatasetConfig& c);

// The release-wide files, once every job is done (an Error naming the jobs that are not).
Result<ReleaseSummary> finish_release(const DatasetConfig& c, const ReleasePlan& plan, const DatasetStatus& status,
                                      const Splits& splits, const std::vector<CatalogSession>& sessions);

// SHA256SUMS over every other file under `out`, rewritten (also after a withdrawal purged a
// participant's folder from the release).
Result<std::size_t> write_sha256sums(const std::filesystem::path& out);

// The Croissant 1.0 description of the release (the fields its specification requires, the files
// as FileObjects and FileSets, the sequences as a RecordSet read from their paths).
nlohmann::json croissant_metadata(const DatasetConfig& c, const ReleasePlan& plan, const std::string& date,
                                  const std::string& readme_sha256, const std::string& splits_sha256);

}  // namespace pvcap::dataset
