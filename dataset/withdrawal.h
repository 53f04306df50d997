#pragma once
// A participant's withdrawal of consent (`pvcap dataset withdraw`): what it refuses, what it writes
// (the withdrawal's record, the splits without them), and, when purged, what it deletes (their
// folders in every release that holds them, with the release's manifest and SHA256SUMS rewritten,
// and their session folders). The app only prints the report.
#include <cstdint>
#include <string>
#include <vector>

#include "core/result.h"
#include "dataset/catalog.h"
#include "dataset/dataset_folder.h"

namespace pvcap::dataset {

struct WithdrawRequest {
  std::string participant, reason;
  bool purge = false;        // also delete their released folders and their session folders
  std::int64_t wall_ns = 0;  // when (the record's time)
};

struct WithdrawReport {
  std::vector<std::string> session_folders;  // theirs: out of the catalogue; deleted when purged
  struct Release {
    std::string out;     // a release that holds them
    std::string folder;  // their folder in it ("" when its participants.json does not name them)
    bool removed = false;
  };
  std::vector<Release> releases;
  bool splits_rewritten = false;
  bool sessions_removed = false;
};

// Refused (an Error, nothing written) when `participant` is not a participant code, has withdrawn
// already, or is not among `participants` (the catalogue's). `sessions`: the catalogue's folders.
Result<WithdrawReport> withdraw(const DatasetConfig& config, const std::vector<std::string>& participants,
                                const std::vector<CatalogSession>& sessions, const WithdrawRequest& request);

}  // namespace pvcap::dataset
