#include "dataset/withdrawal.h"

#include <algorithm>
#include <filesystem>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "core/durable_folder.h"
#include "dataset/release.h"
#include "storage/index/records.h"

namespace pvcap::dataset {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

Status write_json(const fs::path& file, const json& j) {
  return write_file_atomically(file, j.dump(2) + "\n", Durability::Synced);
}

// The splits without the participant; false when there are none yet.
Result<bool> remove_from_splits(const fs::path& dir, const std::string& participant) {
  json j = read_json_file(dir / "splits.json", nullptr);
  if (j.is_null()) return false;
  Splits s = splits_from_json(j, dir / "splits.json");
  for (auto* v : {&s.train, &s.val, &s.test}) v->erase(std::remove(v->begin(), v->end(), participant), v->end());
  j["train"] = s.train;
  j["val"] = s.val;
  j["test"] = s.test;
  if (Status w = write_json(dir / "splits.json", j); !w.ok()) return w.error();
  return true;
}

// Their folder out of a release: the folder, its entry in participants.json, SHA256SUMS again.
Status purge_from_release(const fs::path& out, const std::string& folder, const std::string& participant) {
  std::error_code ec;
  fs::remove_all(out / folder, ec);
  if (ec) return Error{fmt::format("{}: cannot be removed: {}", (out / folder).string(), ec.message())};
  json map = read_json_file(out / "participants.json", json::object());
  map.erase(participant);
  if (Status w = write_json(out / "participants.json", map); !w.ok()) return w;
  if (auto sums = write_sha256sums(out); !sums) return sums.error();
  return {};
}

}  // namespace

Result<WithdrawReport> withdraw(const DatasetConfig& config, const std::vector<std::string>& participants,
                                const std::vector<CatalogSession>& sessions, const WithdrawRequest& r) {
  if (!is_pseudonymous_code(r.participant))
    return Error{fmt::format("'{}' is not a participant code (letters, digits, - and _)", r.participant)};
  if (is_withdrawn(load_withdrawals(config.dir), r.participant))
    return Error{
        fmt::format("{} has withdrawn already ({})", r.participant, (config.dir / "withdrawals.json").string())};
  if (std::find(participants.begin(), participants.end(), r.participant) == participants.end())
    return Error{fmt::format("no participant {} in dataset {} (participants: {})", r.participant, config.name,
                             fmt::join(participants, ", "))};
  WithdrawReport report;
  Withdrawal w{r.participant, r.reason, r.wall_ns, {}, r.purge};
  for (const auto& release : load_releases(config.dir)) {
    if (std::find(release.participants.begin(), release.participants.end(), r.participant) ==
        release.participants.end())
      continue;
    w.releases_named.push_back(release.out);
    const json map = read_json_file(fs::path(release.out) / "participants.json", json::object());
    const std::string folder =
        map.contains(r.participant) && map[r.participant].is_string() ? map[r.participant].get<std::string>() : "";
    report.releases.push_back({release.out, folder, false});
  }
  for (const auto& s : sessions)
    if (s.participant == r.participant) report.session_folders.push_back(s.folder);
  // The record first: from here on the participant is out of the catalogue and of every later release.
  if (Status s = add_withdrawal(config.dir, w); !s.ok()) return s.error();
  auto splits = remove_from_splits(config.dir, r.participant);
  if (!splits) return splits.error();
  report.splits_rewritten = splits.value();
  if (!r.purge) return report;
  for (auto& release : report.releases) {
    if (release.folder.empty()) continue;
    if (Status s = purge_from_release(release.out, release.folder, r.participant); !s.ok()) return s.error();
    release.removed = true;
  }
  for (const auto& folder : report.session_folders) {
    std::error_code ec;
    fs::remove_all(folder, ec);
    if (ec) return Error{fmt::format("{}: cannot be removed: {}", folder, ec.message())};
  }
  report.sessions_removed = true;
  return report;
}

}  // namespace pvcap::dataset
