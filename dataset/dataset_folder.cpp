#include "dataset/dataset_folder.h"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "core/durable_folder.h"
#include "core/yaml_map_reader.h"

namespace pvcap::dataset {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

std::vector<std::string> strings(MapReader& r, const char* key) {
  std::vector<std::string> out;
  const YAML::Node n = r.child(key);
  if (!n) return out;
  if (!n.IsSequence()) r.fail(n, key, "expected a list");
  for (const auto& v : n) {
    if (!v.IsScalar()) r.fail(v, key, "expected a list of single values");
    out.push_back(v.Scalar());
  }
  return out;
}

fs::path under(const fs::path& dir, const std::string& p) {
  const fs::path path(p);
  return (path.is_absolute() ? path : dir / path).lexically_normal();
}

}  // namespace

DatasetConfig load_dataset(const fs::path& dir_given) {
  const fs::path dir = fs::absolute(dir_given).lexically_normal();
  const fs::path file = dir / "dataset.yaml";
  std::ifstream in(file);
  if (!in)
    throw UserError(
        fmt::format("{}: no dataset here (make one with `pvcap dataset init {} --protocol FILE "
                    "--sessions ROOT`)",
                    file.string(), dir_given.string()));
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_dataset(ss.str(), dir);
}

DatasetConfig parse_dataset(const std::string& text, const fs::path& dir) {
  DatasetConfig c;
  c.dir = dir;
  const fs::path file = c.dir / "dataset.yaml";
  const YAML::Node root = load_yaml(text, file);
  MapReader r(root, file, "");
  r.require("name", c.name);
  if (c.name.empty()) r.fail(root["name"], "name", "must not be empty (it names the release)");
  r.get("description", c.description);
  r.get("license", c.license);
  r.get("url", c.url);
  c.creators = strings(r, "creators");
  std::string protocol;
  r.require("protocol", protocol);
  c.protocol = under(c.dir, protocol);
  for (const auto& s : strings(r, "sessions")) c.session_roots.push_back(under(c.dir, s));
  if (c.session_roots.empty()) r.fail(root, "sessions", "expected at least one folder of sessions");
  c.planned_participants = strings(r, "participants");
  c.conditions = strings(r, "conditions");
  if (auto t = r.child("qa")) {
    MapReader tr(t, file, "qa");
    tr.get_in_range("max_lost_percent", c.thresholds.max_lost_percent, 0.0, 100.0);
    tr.get_in_range("max_sync_offset_ms", c.thresholds.max_sync_offset_ms, 0.0, 1000.0);
    tr.finish();
  }
  r.finish();
  return c;
}

Status write_dataset(const DatasetConfig& c) {
  const fs::path file = c.dir / "dataset.yaml";
  if (fs::exists(file))
    return Error{fmt::format("{}: exists already; edit it, or choose another folder", file.string())};
  std::error_code ec;
  fs::create_directories(c.dir, ec);
  if (ec) return Error{fmt::format("{}: cannot be made: {}", c.dir.string(), ec.message())};
  YAML::Emitter y;
  y << YAML::BeginMap;
  y << YAML::Key << "name" << YAML::Value << c.name;
  y << YAML::Key << "description" << YAML::Value << c.description;
  y << YAML::Key << "license" << YAML::Value << c.license;
  y << YAML::Key << "url" << YAML::Value << c.url;
  y << YAML::Key << "creators" << YAML::Value << YAML::Flow << c.creators;
  y << YAML::Key << "protocol" << YAML::Value << c.protocol.string();
  std::vector<std::string> roots;
  for (const auto& r : c.session_roots) roots.push_back(r.string());
  y << YAML::Key << "sessions" << YAML::Value << roots;
  y << YAML::Key << "participants" << YAML::Value << YAML::Flow << c.planned_participants;
  y << YAML::Key << "conditions" << YAML::Value << YAML::Flow << c.conditions;
  y << YAML::Key << "qa" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "max_lost_percent" << YAML::Value << c.thresholds.max_lost_percent;
  y << YAML::Key << "max_sync_offset_ms" << YAML::Value << c.thresholds.max_sync_offset_ms;
  y << YAML::EndMap << YAML::EndMap;
  const std::string text = fmt::format(
      "# A pvcap dataset (docs/dataset.md). The sessions under `sessions` are its only source of truth;\n"
      "# catalog.db is derived from them. `participants` (codes) and `conditions` (lighting) are what is\n"
      "# planned, for the completeness matrix; license, url and creators go into the release's metadata.\n{}\n",
      y.c_str());
  return write_file_atomically(file, text, Durability::Synced);
}

json read_json_file(const fs::path& file, const json& otherwise) {
  std::ifstream in(file);
  if (!in) return otherwise;
  json j = json::parse(in, nullptr, false);
  if (j.is_discarded())
    throw UserError(
        fmt::format("{}: is not JSON; it is one of the dataset's records: restore it from a backup", file.string()));
  return j;
}

RecordReader::RecordReader(const json& j, fs::path file) : j_(j), file_(std::move(file)) {
  if (!j_.is_object()) fail("", "an object");
}

void RecordReader::fail(const std::string& key, const char* what) const {
  throw UserError(fmt::format("{}: {} is not {}; the file is one of the dataset's records: restore it from a backup",
                              file_.string(), key.empty() ? "an entry" : "'" + key + "'", what));
}

std::string RecordReader::text(const char* key) const {
  if (!j_.contains(key)) return "";
  if (!j_[key].is_string()) fail(key, "text");
  return j_[key].get<std::string>();
}

std::int64_t RecordReader::integer(const char* key) const {
  if (!j_.contains(key)) return 0;
  if (!j_[key].is_number_integer()) fail(key, "an integer");
  return j_[key].get<std::int64_t>();
}

bool RecordReader::flag(const char* key) const {
  if (!j_.contains(key)) return false;
  if (!j_[key].is_boolean()) fail(key, "true or false");
  return j_[key].get<bool>();
}

std::vector<std::string> RecordReader::texts(const char* key) const {
  std::vector<std::string> out;
  if (!j_.contains(key)) return out;
  if (!j_[key].is_array()) fail(key, "a list of text");
  for (const auto& v : j_[key]) {
    if (!v.is_string()) fail(key, "a list of text");
    out.push_back(v.get<std::string>());
  }
  return out;
}

std::vector<Withdrawal> parse_withdrawals(const json& j, const fs::path& file) {
  if (!j.is_array()) RecordReader(json::object(), file).fail("", "a list of withdrawals");
  std::vector<Withdrawal> out;
  for (const auto& w : j) {
    const RecordReader r(w, file);
    Withdrawal x;
    x.participant = r.text("participant");
    x.reason = r.text("reason");
    x.wall_ns = r.integer("wall_ns");
    x.releases_named = r.texts("releases_named");
    x.purged = r.flag("purged");
    out.push_back(std::move(x));
  }
  return out;
}

std::vector<Withdrawal> load_withdrawals(const fs::path& dir) {
  return parse_withdrawals(read_json_file(dir / "withdrawals.json", json::array()), dir / "withdrawals.json");
}

Status add_withdrawal(const fs::path& dir, const Withdrawal& w) {
  json j = read_json_file(dir / "withdrawals.json", json::array());
  j.push_back({{"participant", w.participant},
               {"reason", w.reason},
               {"wall_ns", w.wall_ns},
               {"releases_named", w.releases_named},
               {"purged", w.purged}});
  return write_file_atomically(dir / "withdrawals.json", j.dump(2) + "\n", Durability::Synced);
}

bool is_withdrawn(const std::vector<Withdrawal>& w, const std::string& participant) {
  for (const auto& x : w)
    if (x.participant == participant) return true;
  return false;
}

std::vector<ReleaseRecord> parse_releases(const json& j, const fs::path& file) {
  if (!j.is_array()) RecordReader(json::object(), file).fail("", "a list of releases");
  std::vector<ReleaseRecord> out;
  for (const auto& e : j) {
    const RecordReader r(e, file);
    ReleaseRecord x;
    x.out = r.text("out");
    x.wall_ns = r.integer("wall_ns");
    x.participants = r.texts("participants");
    out.push_back(std::move(x));
  }
  return out;
}

std::vector<ReleaseRecord> load_releases(const fs::path& dir) {
  return parse_releases(read_json_file(dir / "releases.json", json::array()), dir / "releases.json");
}

Status record_release(const fs::path& dir, const ReleaseRecord& r) {
  json j = read_json_file(dir / "releases.json", json::array());
  json kept = json::array();
  for (const auto& e : parse_releases(j, dir / "releases.json"))
    if (e.out != r.out)  // made again into the same folder: the new record
      kept.push_back({{"out", e.out}, {"wall_ns", e.wall_ns}, {"participants", e.participants}});
  kept.push_back({{"out", r.out}, {"wall_ns", r.wall_ns}, {"participants", r.participants}});
  return write_file_atomically(dir / "releases.json", kept.dump(2) + "\n", Durability::Synced);
}

}  // namespace pvcap::dataset
