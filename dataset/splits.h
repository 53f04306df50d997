#pragma once
// Participant-held-out splits, as the paper's test set of unseen participants: every participant
// is in exactly one of train, val and test, so no person's hands are seen in training and judged
// in testing. Drawn at random from a seed (the same seed, the same splits), balanced over skin
// tone and lighting where the counts allow: each stratum (skin tone x lighting) gives test and val
// their share of it, by largest remainder. The leakage check that status and release also run.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/result.h"

#include "dataset/dataset_folder.h"
#include "storage/index/catalog_db.h"

namespace pvcap::dataset {

struct SplitCandidate {
  std::string code, skin_tone, lighting;
};

struct Splits {
  std::uint64_t seed = 0;
  std::vector<std::string> train, val, test;
};

// Throws UserError when test + val leave no participant for training.
Splits make_splits(std::vector<SplitCandidate> candidates, int test, int val, std::uint64_t seed);
nlohmann::json splits_json(const Splits& s, const std::vector<SplitCandidate>& candidates);
// Reads splits.json's content strictly (a UserError naming `file` for a key of the wrong type).
Splits splits_from_json(const nlohmann::json& j, const std::filesystem::path& file);
// DIR/splits.json, written whole (splits_json), and read as splits_from_json reads it (nullopt when
// the dataset has none yet).
Status save_splits(const std::filesystem::path& dataset_dir, const Splits& s,
                   const std::vector<SplitCandidate>& candidates);
std::optional<Splits> load_splits(const std::filesystem::path& dataset_dir);

// What is wrong with the splits against the catalogue: a participant in two splits, a resumed
// session whose folders belong to different participants (so could land in two splits), a
// withdrawn participant still in a split, a catalogued participant in none. Empty: no leakage.
std::vector<std::string> leakage_problems(const Splits& s, const std::vector<CatalogSession>& sessions,
                                          const std::vector<Withdrawal>& withdrawals);

}  // namespace pvcap::dataset
