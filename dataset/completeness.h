#pragma once
// What the catalogue says about the dataset as a whole: the completeness matrix (participant x hand
// x action: done, bad, superseded, missing), the QA flags, and per participant what remains to
// record, as (action, hand) pairs and as a protocol file of only those takes that
// `pvcap session --protocol` runs. Pure: from the catalogue's rows, the protocol and the
// dataset's declarations, no file read.
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "dataset/dataset_folder.h"
#include "protocol/protocol.h"
#include "storage/index/catalog_db.h"

namespace pvcap::dataset {

// One cell: the best of the takes recorded for it, in this order: done, bad, superseded, missing
// (skipped and interrupted takes leave it missing).
struct Cell {
  std::string status = "missing";
  int done_takes = 0;                  // more than one: a duplicate (which one is the take?)
  std::vector<std::string> sequences;  // every take recorded for it, "<folder name>/<sequence>"
};

struct ParticipantStatus {
  std::string code, skin_tone;
  std::vector<std::string> lighting;  // its sessions' conditions: what their images showed, else their labels
  std::vector<std::string> folders;   // its session folders (resumed chains together), oldest first
  bool planned = true;                // in dataset.yaml's participants (or none are listed)
  std::map<std::pair<std::string, std::string>, Cell> cells;   // (hand, action) -> cell
  std::vector<std::pair<std::string, std::string>> remaining;  // (action, hand) not done, in plan order
};

struct QaFlag {
  std::string participant, folder;  // folder empty: the participant as a whole
  std::string kind;                 // not_verified_clean, losses, sync_offset, no_calibration, take_check,
                                    // duplicate_take, unplanned, condition_unplanned, condition_mismatch,
                                    // no_sessions
  std::string message;              // in words, with the figures
};

struct DatasetStatus {
  std::string name;
  std::vector<std::string> actions;  // the protocol's rows (action at a force level), in order
  std::vector<ParticipantStatus> participants;
  std::vector<QaFlag> flags;
  std::size_t sessions = 0, withdrawn = 0;
};

DatasetStatus compute_status(const DatasetConfig& c, const protocol::Protocol& p,
                             const std::vector<CatalogSession>& sessions, const std::vector<CatalogTake>& takes,
                             const std::vector<Withdrawal>& withdrawals);

nlohmann::json status_json(const DatasetStatus& s);
std::string format_status(const DatasetStatus& s);

// The protocol of only `ps.remaining`: the dataset's protocol with each remaining (action, hand) as
// one action entry restricted to that hand (`hands:`), pictograms named relative to
// `pictogram_folder` (the caller copies them there). Empty string when nothing remains.
std::string remaining_protocol_yaml(const protocol::Protocol& p, const ParticipantStatus& ps,
                                    const std::string& pictogram_folder);

}  // namespace pvcap::dataset
