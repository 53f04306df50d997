#include "dataset/status_files.h"

#include <filesystem>
#include <system_error>

#include <fmt/format.h>

#include "core/durable_folder.h"
#include "core/result.h"
#include "dataset/dataset_page.h"

namespace pvcap::dataset {

namespace fs = std::filesystem;

namespace {
void write_remaining_protocols(const DatasetConfig& c, const protocol::Protocol& p, const DatasetStatus& status) {
  const fs::path folder = c.dir / "remaining";
  std::error_code ec;
  fs::create_directories(folder / "pictograms", ec);
  if (ec) throw UserError(fmt::format("{}: cannot be made: {}", folder.string(), ec.message()));
  for (const auto& a : p.actions) {
    const fs::path to = folder / "pictograms" / fs::path(a.pictogram).filename();
    fs::copy_file(a.pictogram, to, fs::copy_options::overwrite_existing, ec);
    if (ec) throw UserError(fmt::format("{}: cannot be copied to {}: {}", a.pictogram, to.string(), ec.message()));
  }
  for (const auto& ps : status.participants) {
    const fs::path file = folder / (ps.code + ".yaml");
    const std::string text = remaining_protocol_yaml(p, ps, "pictograms");
    if (text.empty()) {
      fs::remove(file, ec);
      continue;
    }
    if (auto w = write_file_atomically(file, text, Durability::Synced); !w.ok()) throw UserError(w.error().message);
  }
}
}  // namespace

nlohmann::json write_status_files(const DatasetConfig& c, const protocol::Protocol& p, const DatasetStatus& status,
                                  const std::vector<std::string>& leakage) {
  write_remaining_protocols(c, p, status);
  nlohmann::json j = status_json(status);
  if (auto w = write_file_atomically(c.dir / "dataset.html", render_dataset_html(j, leakage), Durability::Synced);
      !w.ok())
    throw UserError(w.error().message);
  return j;
}

}  // namespace pvcap::dataset
