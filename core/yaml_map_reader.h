#pragma once
// Strict reading of one YAML mapping for configuration files (rig files,
// protocols): typed values with ranges, required keys, and unknown keys as
// errors, each failure a UserError naming file:line and the key's path.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <optional>
#include <set>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "core/result.h"

namespace pvcap {

// Parses a configuration file's text; a syntax error is a UserError naming file:line.
inline YAML::Node load_yaml(const std::string& text, const std::filesystem::path& source) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw UserError(fmt::format("{}:{}: YAML syntax error: {}", source.string(), e.mark.line + 1, e.msg));
  }
}

// Reads one YAML map, remembering which keys were used so leftovers are errors.
class MapReader {
 public:
  MapReader(const YAML::Node& node, const std::filesystem::path& file, std::string where)
      : node_(node), file_(file), where_(std::move(where)) {
    if (!node_.IsMap()) fail(node_, "", "expected a mapping of key: value");
  }

  [[noreturn]] void fail(const YAML::Node& at, const std::string& key, const std::string& what) const {
    raise(at, key, what);
  }
  // Something missing: a required key, or one of a pair ("needs a 'serial' or an 'address'"). A
  // misspelt key (`serail:`) is its likely cause, so that is said first, with the key it meant.
  [[noreturn]] void fail_missing(const YAML::Node& at, const std::string& key, const std::string& what) const {
    if (const auto m = misspelt_key())
      raise(m->first, m->first.Scalar(), fmt::format("unknown key; did you mean '{}'?", m->second));
    raise(at, key, what);
  }

  bool has(const char* key) const { return bool(node_[key]); }

  YAML::Node child(const char* key) {
    used_.insert(key);
    return node_[key];
  }

  template <typename T>
  void get(const char* key, T& out) {
    used_.insert(key);
    const YAML::Node v = node_[key];
    if (!v) return;
    if (!v.IsScalar()) fail(v, key, "expected a single value");
    try {
      out = v.as<T>();
    } catch (const YAML::Exception&) {
      fail(v, key, fmt::format("'{}' is not a valid {}", v.Scalar(), type_name<T>()));
    }
  }

  template <typename T>
  void require(const char* key, T& out) {
    if (!has(key)) {
      used_.insert(key);  // the key it may be a typo of
      fail_missing(node_, key, "missing (required)");
    }
    get(key, out);
  }

  template <typename T>
  void get_in_range(const char* key, T& out, T lo, T hi) {
    get(key, out);
    if (has(key) && (out < lo || out > hi || (std::is_floating_point_v<T> && std::isnan(double(out)))))
      fail(node_[key], key, fmt::format("{} is out of range [{}, {}]", out, lo, hi));
  }

  // An optional value: set only when the key is given (and then in range).
  template <typename T>
  void get_in_range(const char* key, std::optional<T>& out, T lo, T hi) {
    used_.insert(key);
    if (!has(key)) return;
    T v{};
    get_in_range(key, v, lo, hi);
    out = v;
  }

  // A list of exactly `n` numbers, e.g. position_mm: [115, 65, 480].
  template <std::size_t N>
  void get_numbers(const char* key, std::optional<std::array<double, N>>& out) {
    used_.insert(key);
    const YAML::Node v = node_[key];
    if (!v) return;
    if (!v.IsSequence() || v.size() != N) fail(v, key, fmt::format("expected a list of {} numbers", N));
    std::array<double, N> a{};
    for (std::size_t i = 0; i < N; ++i) {
      try {
        a[i] = v[i].as<double>();
      } catch (const YAML::Exception&) {
        fail(v[i], key, fmt::format("'{}' is not a number", v[i].IsScalar() ? v[i].Scalar() : "?"));
      }
      if (!std::isfinite(a[i])) fail(v[i], key, "must be a finite number");
    }
    out = a;
  }

  // Unknown keys are errors: a misspelt "frame_rat" must not silently become the default.
  void finish() const {
    if (const auto m = misspelt_key())
      raise(m->first, m->first.Scalar(), fmt::format("unknown key; did you mean '{}'?", m->second));
    for (const auto& kv : node_) {
      const std::string k = kv.first.Scalar();
      if (!used_.count(k)) {
        std::string known;
        for (const auto& u : used_) known += (known.empty() ? "" : ", ") + u;
        raise(kv.first, k, fmt::format("unknown key (known here: {})", known));
      }
    }
  }

  const YAML::Node& node() const { return node_; }

 private:
  [[noreturn]] void raise(const YAML::Node& at, const std::string& key, const std::string& what) const {
    const std::string path = key.empty() ? where_ : (where_.empty() ? key : where_ + "." + key);
    throw UserError(
        fmt::format("{}:{}: {}{}{}", file_.string(), at.Mark().line + 1, path, path.empty() ? "" : ": ", what));
  }

  // Edits (insert, delete, change, swap two neighbours) from a to b: a typo is one or two.
  static std::size_t edit_distance(const std::string& a, const std::string& b) {
    std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
    for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
    for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i)
      for (std::size_t j = 1; j <= b.size(); ++j) {
        d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + (a[i - 1] != b[j - 1])});
        if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
          d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
      }
    return d[a.size()][b.size()];
  }

  // A key not read here that is a typo of one that is (so far), with that key.
  std::optional<std::pair<YAML::Node, std::string>> misspelt_key() const {
    if (!node_.IsMap()) return std::nullopt;
    for (const auto& kv : node_) {
      const std::string k = kv.first.Scalar();
      if (used_.count(k)) continue;
      for (const auto& u : used_)
        if (k.size() > 3 && edit_distance(k, u) <= (u.size() > 5 ? 2u : 1u)) return std::make_pair(kv.first, u);
    }
    return std::nullopt;
  }

  template <typename T>
  static const char* type_name() {
    if constexpr (std::is_same_v<T, bool>)
      return "boolean (true/false)";
    else if constexpr (std::is_integral_v<T>)
      return "integer";
    else if constexpr (std::is_floating_point_v<T>)
      return "number";
    else
      return "string";
  }

  YAML::Node node_;
  const std::filesystem::path& file_;
  std::string where_;
  std::set<std::string> used_;
};

}  // namespace pvcap
