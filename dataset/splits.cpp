#include "dataset/splits.h"

#include <algorithm>
#include <map>
#include <numeric>
#include <random>
#include <set>

#include <fmt/format.h>

#include "core/durable_folder.h"
#include "dataset/dataset_folder.h"

namespace pvcap::dataset {

using json = nlohmann::json;

namespace {

// Fisher-Yates with a generator the standard fixes (std::shuffle's algorithm is the library's own):
// the same seed gives the same splits on every machine.
template <typename T>
void shuffle(std::vector<T>& v, std::mt19937_64& g) {
  for (std::size_t i = v.size(); i > 1; --i) std::swap(v[i - 1], v[std::size_t(g() % i)]);
}

// Shares of `n` over strata of the given sizes, proportional, by largest remainder; ties drawn at
// random (else the first stratum by name would always give its member to the test set).
std::vector<int> apportion(const std::vector<int>& sizes, int n, std::mt19937_64& g) {
  const int total = std::max(1, std::accumulate(sizes.begin(), sizes.end(), 0));
  std::vector<int> share(sizes.size());
  std::vector<std::pair<double, std::size_t>> remainder;
  int given = 0;
  for (std::size_t i = 0; i < sizes.size(); ++i) {
    const double exact = double(n) * sizes[i] / total;
    share[i] = std::min(sizes[i], int(exact));
    given += share[i];
    remainder.push_back({exact - share[i], i});
  }
  shuffle(remainder, g);
  std::stable_sort(remainder.begin(), remainder.end(), [](auto& a, auto& b) { return a.first > b.first; });
  for (std::size_t k = 0; given < n && k < remainder.size() * 2; ++k) {
    const std::size_t i = remainder[k % remainder.size()].second;
    if (share[i] < sizes[i]) {
      ++share[i];
      ++given;
    }
  }
  return share;
}

}  // namespace

Splits make_splits(std::vector<SplitCandidate> candidates, int test, int val, std::uint64_t seed) {
  const int n = int(candidates.size());
  if (test < 0 || val < 0 || test + val >= n)
    throw UserError(
        fmt::format("--test {} and --val {} leave no participant for training ({} catalogued)", test, val, n));
  std::sort(candidates.begin(), candidates.end(), [](auto& a, auto& b) { return a.code < b.code; });
  std::mt19937_64 g(seed);
  shuffle(candidates, g);
  std::map<std::string, std::vector<std::string>> strata;  // skin tone / lighting -> codes, shuffled
  for (const auto& c : candidates) strata[c.skin_tone + "/" + c.lighting].push_back(c.code);
  std::vector<int> sizes;
  for (const auto& [k, codes] : strata) sizes.push_back(int(codes.size()));
  const std::vector<int> test_share = apportion(sizes, test, g);
  std::vector<int> left(sizes);
  for (std::size_t i = 0; i < left.size(); ++i) left[i] -= test_share[i];
  const std::vector<int> val_share = apportion(left, val, g);
  Splits s;
  s.seed = seed;
  std::size_t i = 0;
  for (const auto& [k, codes] : strata) {
    for (std::size_t j = 0; j < codes.size(); ++j) {
      auto& split = int(j) < test_share[i] ? s.test : int(j) < test_share[i] + val_share[i] ? s.val : s.train;
      split.push_back(codes[j]);
    }
    ++i;
  }
  for (auto* v : {&s.train, &s.val, &s.test}) std::sort(v->begin(), v->end());
  return s;
}

json splits_json(const Splits& s, const std::vector<SplitCandidate>& candidates) {
  json strata = json::object();
  std::map<std::string, std::string> split_of;
  for (const auto& c : s.train) split_of[c] = "train";
  for (const auto& c : s.val) split_of[c] = "val";
  for (const auto& c : s.test) split_of[c] = "test";
  for (const auto& c : candidates) {
    const std::string key = c.skin_tone + "/" + c.lighting;
    if (!strata.contains(key)) strata[key] = {{"train", 0}, {"val", 0}, {"test", 0}};
    if (split_of.count(c.code)) strata[key][split_of[c.code]] = strata[key][split_of[c.code]].get<int>() + 1;
  }
  return {
      {"held_out_by", "participant"},         {"seed", s.seed}, {"train", s.train}, {"val", s.val}, {"test", s.test},
      {"strata (skin tone/lighting)", strata}};
}

Splits splits_from_json(const json& j, const std::filesystem::path& file) {
  const RecordReader r(j, file);
  Splits s;
  s.seed = std::uint64_t(r.integer("seed"));
  s.train = r.texts("train");
  s.val = r.texts("val");
  s.test = r.texts("test");
  return s;
}

std::vector<std::string> leakage_problems(const Splits& s, const std::vector<CatalogSession>& sessions,
                                          const std::vector<Withdrawal>& withdrawals) {
  std::vector<std::string> out;
  std::map<std::string, std::vector<std::string>> splits_of;
  for (const auto& c : s.train) splits_of[c].push_back("train");
  for (const auto& c : s.val) splits_of[c].push_back("val");
  for (const auto& c : s.test) splits_of[c].push_back("test");
  for (const auto& [code, in] : splits_of) {
    if (in.size() > 1)
      out.push_back(fmt::format("participant {} is in {} splits ({})", code, in.size(), fmt::join(in, ", ")));
    if (is_withdrawn(withdrawals, code))
      out.push_back(fmt::format("participant {} withdrew but is in {}", code, in[0]));
  }
  std::map<std::string, std::set<std::string>> chain_participants;  // original folder -> participants
  std::set<std::string> catalogued;
  for (const auto& x : sessions) {
    chain_participants[x.original].insert(x.participant);
    catalogued.insert(x.participant);
  }
  for (const auto& [original, who] : chain_participants)
    if (who.size() > 1)
      out.push_back(
          fmt::format("the resumed session {} continues under {} participants ({}): its folders would "
                      "land in different splits",
                      original, who.size(), fmt::join(who, ", ")));
  for (const auto& code : catalogued)
    if (!splits_of.count(code) && !is_withdrawn(withdrawals, code))
      out.push_back(
          fmt::format("participant {} is in no split (recorded after the split: run `pvcap dataset split` "
                      "again)",
                      code));
  return out;
}

Status save_splits(const std::filesystem::path& dataset_dir, const Splits& s,
                   const std::vector<SplitCandidate>& candidates) {
  return write_file_atomically(dataset_dir / "splits.json", splits_json(s, candidates).dump(2) + "\n",
                               Durability::Synced);
}

std::optional<Splits> load_splits(const std::filesystem::path& dataset_dir) {
  const std::filesystem::path file = dataset_dir / "splits.json";
  const nlohmann::json j = read_json_file(file, nullptr);
  if (j.is_null()) return std::nullopt;
  return splits_from_json(j, file);
}

}  // namespace pvcap::dataset
