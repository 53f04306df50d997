#pragma once
// A dataset folder and the files `pvcap dataset` keeps in it:
//   dataset.yaml       what the lab declares: name, protocol, the sessions' roots, the planned
//                      participants and conditions, the QA thresholds, the release's licence and
//                      creators (written by `pvcap dataset init`, edited by hand)
//   catalog.db         derived from the sessions (storage/index/catalog_db.h); can always be rebuilt
//   splits.json        the participant-held-out splits
//   withdrawals.json   who withdrew consent, when and why (codes only: no personal data)
//   releases.json      every release made: where, when, which participants it holds
// The sessions stay the only source of truth: nothing here writes into a session folder.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/result.h"

namespace pvcap::dataset {

struct Thresholds {
  double max_lost_percent = 1.0;    // frames the devices numbered that never arrived, per stream
  double max_sync_offset_ms = 2.0;  // the self-check's estimate beyond this (and two standard errors)
};

struct DatasetConfig {
  std::filesystem::path dir;  // the dataset folder (absolute)
  std::string name, description, license, url;
  std::vector<std::string> creators;
  std::filesystem::path protocol;                    // absolute
  std::vector<std::filesystem::path> session_roots;  // absolute
  std::vector<std::string> planned_participants;     // codes; may be empty
  std::vector<std::string> conditions;               // lighting conditions planned, e.g. LCR; may be empty
  Thresholds thresholds;
};

// Reads DIR/dataset.yaml; a bad file is a UserError naming file:line and key; relative paths in it
// are relative to the dataset folder.
DatasetConfig load_dataset(const std::filesystem::path& dir);
DatasetConfig parse_dataset(const std::string& text, const std::filesystem::path& dir);
// Writes DIR/dataset.yaml (refuses to overwrite one).
Status write_dataset(const DatasetConfig& c);

struct Withdrawal {
  std::string participant, reason;
  std::int64_t wall_ns = 0;
  std::vector<std::string> releases_named;  // the release folders that held the participant
  bool purged = false;
};
std::vector<Withdrawal> load_withdrawals(const std::filesystem::path& dir);
std::vector<Withdrawal> parse_withdrawals(const nlohmann::json& j, const std::filesystem::path& file);
Status add_withdrawal(const std::filesystem::path& dir, const Withdrawal& w);
bool is_withdrawn(const std::vector<Withdrawal>& w, const std::string& participant);

struct ReleaseRecord {
  std::string out;  // absolute
  std::int64_t wall_ns = 0;
  std::vector<std::string> participants;
};
std::vector<ReleaseRecord> load_releases(const std::filesystem::path& dir);
std::vector<ReleaseRecord> parse_releases(const nlohmann::json& j, const std::filesystem::path& file);
Status record_release(const std::filesystem::path& dir, const ReleaseRecord& r);

// One entry of a record file read strictly: a key of the wrong type is a UserError naming the file
// and the key (the files are edited by hand now and then), never a library's exception.
class RecordReader {
 public:
  RecordReader(const nlohmann::json& j, std::filesystem::path file);
  std::string text(const char* key) const;  // "" when absent
  std::int64_t integer(const char* key) const;
  bool flag(const char* key) const;
  std::vector<std::string> texts(const char* key) const;
  [[noreturn]] void fail(const std::string& key, const char* what) const;

 private:
  const nlohmann::json& j_;
  std::filesystem::path file_;
};

nlohmann::json read_json_file(const std::filesystem::path& file, const nlohmann::json& otherwise);

}  // namespace pvcap::dataset
