#pragma once
// What `pvcap.Dataset` reads from a dataset folder (dataset/dataset_folder.h): its catalogue's
// sessions with their QA verdicts and splits, without the participants who withdrew. Read-only:
// the catalogue is read as `pvcap dataset status` last wrote it.
#include <filesystem>
#include <string>
#include <vector>

#include "core/result.h"

namespace pvcap::python {

struct DatasetSession {
  std::string folder, participant, skin_tone, hand_order, lighting, protocol;
  int verify_exit = 0;     // pvcap verify's: 0 clean, 3 lossy (losses named), 1 failed
  std::string facts_json;  // verify's losses, the report's sync self-check and calibration
  std::string split;       // train, val or test; "" when not in splits.json (or no splits yet)
};

struct DatasetView {
  std::string name;
  std::vector<DatasetSession> sessions;  // by participant, then start; no withdrawn participant's
  std::vector<std::string> withdrawn;    // their codes
  bool has_splits = false;
};

Result<DatasetView> open_dataset(const std::filesystem::path& dir);

}  // namespace pvcap::python
