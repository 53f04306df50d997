// libFuzzer target: the dataset's files as they may be found after a hand edit or a bad copy. The
// first byte picks the file: dataset.yaml (parsed to a config, or a UserError naming file:line),
// or one of the JSON records (withdrawals.json, releases.json, splits.json: read to their values,
// or a UserError naming the file); never a crash, a hang, or a library's own exception.
#include <cstddef>
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "core/result.h"
#include "dataset/dataset_folder.h"
#include "dataset/splits.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  const std::filesystem::path dir = "/fuzz/dataset";
  const std::string kinds[] = {"dataset.yaml", "withdrawals.json", "releases.json", "splits.json"};
  const std::string& kind = kinds[data[0] % 4];
  const std::string file = (dir / kind).string();
  try {
    if (kind == "dataset.yaml") {
      const auto c = pvcap::dataset::parse_dataset(text, dir);
      if (c.name.empty()) __builtin_trap();  // required
      if (c.session_roots.empty() || !c.protocol.is_absolute()) __builtin_trap();
      for (const auto& r : c.session_roots)
        if (!r.is_absolute()) __builtin_trap();
      return 0;
    }
    const auto j = nlohmann::json::parse(text, nullptr, false);
    if (j.is_discarded()) return 0;  // read_json_file says "is not JSON" for these
    if (kind == "withdrawals.json") {
      for (const auto& w : pvcap::dataset::parse_withdrawals(j, file)) (void)pvcap::dataset::is_withdrawn({w}, "P01");
    } else if (kind == "releases.json") {
      (void)pvcap::dataset::parse_releases(j, file);
    } else {
      const auto s = pvcap::dataset::splits_from_json(j, file);
      (void)pvcap::dataset::leakage_problems(s, {}, {});
    }
  } catch (const pvcap::UserError& e) {
    if (std::string(e.what()).rfind(file + ":", 0) != 0) __builtin_trap();  // every error names its file
  }
  return 0;
}
