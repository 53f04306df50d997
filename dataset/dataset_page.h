#pragma once
// DIR/dataset.html: the dataset's status as one self-contained page (no scripts, nothing fetched),
// like the session report: the completeness matrix with a colour per cell, the QA flags, and what
// remains to record per participant; made from status_json.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace pvcap::dataset {

std::string render_dataset_html(const nlohmann::json& status, const std::vector<std::string>& leakage);

}  // namespace pvcap::dataset
