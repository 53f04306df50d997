#pragma once
// The files `pvcap dataset status` leaves in the dataset folder: what each participant still has to
// record, DIR/remaining/<participant>.yaml (the takes completeness.h finds missing, as a protocol
// file that `pvcap session --protocol` runs) with the pictograms beside them, a complete
// participant's old file removed; and the dataset's page, DIR/dataset.html. Files written whole
// (core/durable_folder.h); a failure is a UserError naming the file.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "dataset/completeness.h"

namespace pvcap::dataset {

// Writes both; returns the status as JSON (status_json), what the page shows.
nlohmann::json write_status_files(const DatasetConfig& c, const protocol::Protocol& p, const DatasetStatus& status,
                                  const std::vector<std::string>& leakage);

}  // namespace pvcap::dataset
