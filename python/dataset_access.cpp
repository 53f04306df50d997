#include "python/dataset_access.h"

#include <algorithm>

#include <fmt/format.h>

#include "dataset/dataset_folder.h"
#include "dataset/splits.h"
#include "storage/index/catalog_db.h"

namespace pvcap::python {

Result<DatasetView> open_dataset(const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  try {
    const dataset::DatasetConfig config = dataset::load_dataset(dir);
    const fs::path catalog = config.dir / "catalog.db";
    if (!fs::is_regular_file(catalog))
      return Error{fmt::format("{}: no catalogue yet: run `pvcap dataset status {}` first", catalog.string(),
                               config.dir.string())};
    auto db = CatalogDb::open_read_only(catalog, fmt::format("pvcap dataset status {}", config.dir.string()));
    if (!db) return db.error();
    DatasetView out;
    out.name = config.name;
    const auto withdrawals = dataset::load_withdrawals(config.dir);
    for (const auto& w : withdrawals) out.withdrawn.push_back(w.participant);
    const std::optional<dataset::Splits> loaded = dataset::load_splits(config.dir);
    out.has_splits = loaded.has_value();
    const dataset::Splits splits = loaded.value_or(dataset::Splits{});
    const auto in = [](const std::vector<std::string>& v, const std::string& code) {
      return std::find(v.begin(), v.end(), code) != v.end();
    };
    for (CatalogSession& s : db.value()->sessions()) {
      if (dataset::is_withdrawn(withdrawals, s.participant)) continue;  // never yielded
      DatasetSession d{std::move(s.folder),     s.participant,           std::move(s.skin_tone),
                       std::move(s.hand_order), std::move(s.lighting),   std::move(s.protocol),
                       s.verify_exit,           std::move(s.facts_json), ""};
      d.split = in(splits.train, d.participant)  ? "train"
                : in(splits.val, d.participant)  ? "val"
                : in(splits.test, d.participant) ? "test"
                                                 : "";
      out.sessions.push_back(std::move(d));
    }
    return out;
  } catch (const UserError& e) {
    return Error{e.what()};
  }
}

}  // namespace pvcap::python
