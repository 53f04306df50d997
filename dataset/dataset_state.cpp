#include "dataset/dataset_state.h"

#include <spdlog/spdlog.h>

#include "core/result.h"

namespace pvcap::dataset {

DatasetState open_dataset(const std::filesystem::path& dir, const ScanProgress* scan_progress,
                          const std::atomic<bool>& stop) {
  DatasetState d;
  d.config = load_dataset(dir);
  d.protocol = protocol::load_protocol(d.config.protocol);
  auto db = CatalogDb::open(d.config.dir / "catalog.db");
  if (!db) throw UserError(db.error().message);
  d.db = std::move(db.value());
  if (scan_progress) {
    auto r = scan(d.config, *d.db, *scan_progress, stop);
    if (!r) throw UserError(r.error().message);
    spdlog::info("{}", r.value().summary());
    for (const auto& p : r.value().problems) spdlog::warn("{}", p);
  }
  d.sessions = d.db->sessions();
  d.takes = d.db->takes();
  d.withdrawals = load_withdrawals(d.config.dir);
  d.status = compute_status(d.config, d.protocol, d.sessions, d.takes, d.withdrawals);
  return d;
}

std::vector<std::string> split_leakage(const DatasetState& d) {
  const auto splits = load_splits(d.config.dir);
  if (!splits) return {};
  return leakage_problems(*splits, d.sessions, d.withdrawals);
}

std::vector<SplitCandidate> split_candidates(const DatasetState& d) {
  std::vector<SplitCandidate> out;
  for (const auto& p : d.status.participants)
    if (!p.folders.empty())
      out.push_back({p.code, p.skin_tone, p.lighting.empty() ? "unrecorded" : p.lighting.front()});
  return out;
}

}  // namespace pvcap::dataset
