#include "calib/rig_calibration.h"

#include <algorithm>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include <yaml-cpp/yaml.h>

#include "core/durable_folder.h"

namespace pvcap::calib {

CameraCalibration* RigCalibration::camera(const std::string& name) {
  for (auto& c : cameras)
    if (c.name == name) return &c;
  return nullptr;
}

std::filesystem::path default_calibration_path(const std::filesystem::path& rig_file) {
  return rig_file.parent_path() / (rig_file.stem().string() + ".calibration.yaml");
}

void to_json(nlohmann::json& j, const MeasuredBy& m) {
  j = {{"method", m.method},
       {"session", m.session},
       {"created_wall_ns", m.created_wall_ns},
       {"rms_px", m.rms_px},
       {"details", m.details}};
  if (m.rms_mm) j["rms_mm"] = *m.rms_mm;
}
namespace {
// An integer field, `fallback` when absent. A number that is no integer (1e108) is an error, not a
// conversion: nlohmann's would be undefined behaviour for a value out of the integer's range.
std::int64_t integer_or(const nlohmann::json& j, const char* key, std::int64_t fallback) {
  if (!j.contains(key)) return fallback;
  const auto& v = j.at(key);
  if (!v.is_number_integer())
    throw nlohmann::json::type_error::create(302, fmt::format("'{}' must be an integer", key), &v);
  return v.get<std::int64_t>();
}
}  // namespace

void from_json(const nlohmann::json& j, MeasuredBy& m) {
  m.method = j.at("method").get<std::string>();
  m.session = j.value("session", "");
  m.created_wall_ns = integer_or(j, "created_wall_ns", 0);
  m.rms_px = j.at("rms_px").get<double>();
  if (j.contains("rms_mm")) m.rms_mm = j.at("rms_mm").get<double>();
  m.details = j.value("details", nlohmann::json::object());
}

namespace {
// The file is YAML for people; its content is the JSON model, converted both ways.
void emit(YAML::Emitter& out, const nlohmann::json& j) {
  if (j.is_object()) {
    out << YAML::BeginMap;
    for (auto it = j.begin(); it != j.end(); ++it) {
      out << YAML::Key << it.key() << YAML::Value;
      emit(out, it.value());
    }
    out << YAML::EndMap;
  } else if (j.is_array()) {
    const bool flat = std::all_of(j.begin(), j.end(), [](const auto& v) { return v.is_primitive(); });
    out << (flat ? YAML::Flow : YAML::Block) << YAML::BeginSeq;
    for (const auto& v : j) emit(out, v);
    out << YAML::EndSeq;
  } else if (j.is_string()) {
    out << YAML::DoubleQuoted << j.get<std::string>();
  } else if (j.is_boolean()) {
    out << j.get<bool>();
  } else if (j.is_number_integer()) {
    out << j.get<std::int64_t>();
  } else if (j.is_number()) {
    out << YAML::Precision(17) << j.get<double>();
  } else {
    out << YAML::Null;
  }
}

nlohmann::json to_json_value(const YAML::Node& n) {
  if (n.IsMap()) {
    nlohmann::json j = nlohmann::json::object();
    for (const auto& kv : n) j[kv.first.Scalar()] = to_json_value(kv.second);
    return j;
  }
  if (n.IsSequence()) {
    nlohmann::json j = nlohmann::json::array();
    for (const auto& v : n) j.push_back(to_json_value(v));
    return j;
  }
  if (n.IsNull()) return nullptr;
  if (n.Tag() == "!") return n.Scalar();  // quoted: a string, whatever it looks like
  std::int64_t i = 0;
  double d = 0;
  bool b = false;
  if (YAML::convert<std::int64_t>::decode(n, i)) return i;
  if (YAML::convert<double>::decode(n, d)) return d;
  if (YAML::convert<bool>::decode(n, b)) return b;
  return n.Scalar();
}
}  // namespace

void to_json(nlohmann::json& j, const CameraCalibration& c) {
  j = {{"name", c.name}, {"serial", c.serial}, {"model", c.model}};
  if (c.intrinsics) j["intrinsics"] = *c.intrinsics;
  if (c.pad) {
    j["pad"] = *c.pad;
    j["pad"]["cells_to_ideal_px"] = flat(*c.cells_to_ideal);
    for (const auto& p : *c.pad_corners_px) j["pad"]["pad_corners_px"].push_back({p.x, p.y});
  }
}

void from_json(const nlohmann::json& j, CameraCalibration& c) {
  c.name = j.at("name").get<std::string>();
  c.serial = j.value("serial", "");
  c.model = j.at("model").get<CameraModel>();
  if (j.contains("intrinsics")) c.intrinsics = j.at("intrinsics").get<MeasuredBy>();
  if (j.contains("pad")) {
    c.pad = j.at("pad").get<MeasuredBy>();
    const auto h = j.at("pad").at("cells_to_ideal_px").get<std::vector<double>>();
    if (h.size() != 9) throw nlohmann::json::other_error::create(501, "cells_to_ideal_px needs 9 numbers", &j);
    c.cells_to_ideal = cv::Matx33d(h.data());
    std::array<cv::Point2d, 4> corners;
    for (std::size_t k = 0; k < 4; ++k)
      corners[k] = {j.at("pad").at("pad_corners_px").at(k).at(0).get<double>(),
                    j.at("pad").at("pad_corners_px").at(k).at(1).get<double>()};
    c.pad_corners_px = corners;
  }
}

void to_json(nlohmann::json& j, const RigCalibration& c) {
  j = {{"pvcap_calibration", 1}, {"rig", c.rig}, {"pad_layout", c.pad}, {"cameras", c.cameras}};
}

void from_json(const nlohmann::json& j, RigCalibration& c) {
  if (!j.is_object() || integer_or(j, "pvcap_calibration", 0) != 1)
    throw nlohmann::json::other_error::create(501, "not a pvcap calibration file (no 'pvcap_calibration: 1')", &j);
  c.rig = j.value("rig", "");
  c.pad = j.at("pad_layout").get<PadLayout>();
  c.cameras = j.at("cameras").get<std::vector<CameraCalibration>>();
}

Result<RigCalibration> parse_rig_calibration(const std::string& text, const std::string& source) {
  try {
    return to_json_value(YAML::Load(text)).get<RigCalibration>();
  } catch (const YAML::Exception& e) {
    return Error{fmt::format("{}:{}: YAML syntax error: {}", source, e.mark.line + 1, e.msg)};
  } catch (const nlohmann::json::exception& e) {
    std::string what = e.what();
    if (auto p = what.find("] "); p != std::string::npos) what = what.substr(p + 2);
    return Error{fmt::format("{}: not a usable calibration file: {}", source, what)};
  }
}

Result<RigCalibration> load_rig_calibration(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) return Error{fmt::format("{}: cannot read the calibration file", path.string())};
  std::stringstream text;
  text << in.rdbuf();
  return parse_rig_calibration(text.str(), path.string());
}

Status save_rig_calibration(const std::filesystem::path& path, const RigCalibration& calibration) {
  YAML::Emitter out;
  out.SetIndent(2);
  emit(out, nlohmann::json(calibration));
  const std::string text =
      fmt::format("# pvcap rig calibration: written by `pvcap calibrate`; see docs/calibration.md\n{}\n", out.c_str());
  // Whole or not at all; a failure names the file and the disk's error.
  if (Status s = write_file_atomically(path, text, Durability::Renamed); !s.ok())
    return Error{fmt::format("cannot write the calibration file: {}", s.error().message)};
  return {};
}

}  // namespace pvcap::calib
