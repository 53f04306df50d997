#pragma once
// A dataset as its commands find it: its folder's settings, protocol, catalogue (brought up to date
// by a scan when asked), withdrawals and status, read in that order. What `pvcap dataset status`,
// `split`, `release` and `withdraw` start from.
#include <atomic>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "dataset/catalog.h"
#include "dataset/completeness.h"
#include "dataset/dataset_folder.h"
#include "dataset/splits.h"
#include "dataset/withdrawal.h"
#include "protocol/protocol.h"
#include "storage/index/catalog_db.h"

namespace pvcap::dataset {

struct DatasetState {
  DatasetConfig config;
  protocol::Protocol protocol;
  std::unique_ptr<CatalogDb> db;
  std::vector<CatalogSession> sessions;
  std::vector<CatalogTake> takes;
  std::vector<Withdrawal> withdrawals;
  DatasetStatus status;
};

// The dataset in `dir`; with `scan_progress` given, its session folders are scanned into the
// catalogue first (what the scan found logged, a folder it could not read warned of). A dataset that
// cannot be read throws UserError naming the file.
DatasetState open_dataset(const std::filesystem::path& dir, const ScanProgress* scan_progress,
                          const std::atomic<bool>& stop);

// What would leak between its saved splits (none saved: nothing).
std::vector<std::string> split_leakage(const DatasetState& d);

// The participants a split can place: those with a session, each with the skin tone and the lighting
// its images showed first ("unrecorded" without one).
std::vector<SplitCandidate> split_candidates(const DatasetState& d);

}  // namespace pvcap::dataset
