#include "sim/truth.h"

#include <algorithm>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

namespace pvcap::sim {

const CameraTruth* RigTruth::camera(const std::string& name) const {
  for (const auto& c : cameras)
    if (c.name == name) return &c;
  return nullptr;
}

Result<RigTruth> read_rig_truth(const std::filesystem::path& truth_dir) {
  const auto file = truth_dir / "rig.json";
  std::ifstream in(file);
  if (!in)
    return Error{fmt::format("{}: cannot read it (is {} a simulated run's sim-truth folder?)", file.string(),
                             truth_dir.string())};
  try {
    const auto j = nlohmann::json::parse(in);
    RigTruth t;
    t.t0_ns = j.at("t0_ns").get<std::int64_t>();
    t.pad = j.at("pad").get<calib::PadLayout>();
    for (const auto& c : j.at("cameras")) {
      CameraTruth ct;
      ct.name = c.at("name").get<std::string>();
      ct.model = c.at("model").get<calib::CameraModel>();
      for (std::size_t k = 0; k < 4; ++k)
        ct.pad_corners_px[k] = {c.at("pad_corners_px").at(k).at(0).get<double>(),
                                c.at("pad_corners_px").at(k).at(1).get<double>()};
      t.cameras.push_back(std::move(ct));
    }
    return t;
  } catch (const nlohmann::json::exception& e) {
    return Error{fmt::format("{}: {}", file.string(), e.what())};
  }
}

Result<std::map<std::int64_t, std::int64_t>> read_truth_columns(const std::filesystem::path& file,
                                                                const std::string& key, const std::string& value,
                                                                std::int64_t key_mask) {
  std::ifstream in(file);
  if (!in) return Error{fmt::format("{}: cannot read the simulator's ground truth", file.string())};
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  for (std::stringstream ss(line); std::getline(ss, line, ',');) header.push_back(line);
  const auto k = std::find(header.begin(), header.end(), key), v = std::find(header.begin(), header.end(), value);
  if (k == header.end() || v == header.end())
    return Error{fmt::format("{}: no column '{}'", file.string(), k == header.end() ? key : value)};
  const std::size_t ki = std::size_t(k - header.begin()), vi = std::size_t(v - header.begin());
  std::map<std::int64_t, std::int64_t> out;
  while (std::getline(in, line)) {
    std::vector<std::int64_t> cells;
    try {
      for (std::stringstream ss(line); std::getline(ss, line, ',');) cells.push_back(std::stoll(line));
    } catch (const std::exception&) {
      continue;  // a line cut by a kill: the simulator flushes every 32 frames
    }
    if (cells.size() > std::max(ki, vi)) out[cells[ki] & key_mask] = cells[vi];
  }
  return out;
}

}  // namespace pvcap::sim
