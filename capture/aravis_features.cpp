#include "capture/aravis_features.h"

#include <cmath>
#include <set>

#include <fmt/format.h>

#include "capture/aravis_handles.h"
#include "capture/genicam_node_info.h"

namespace pvcap {

namespace {
ArvGcFeatureNode* feature_node(ArvDevice* device, const std::string& name) {
  ArvGcNode* node = arv_device_get_feature(device, name.c_str());
  return node && ARV_IS_GC_FEATURE_NODE(node) ? ARV_GC_FEATURE_NODE(node) : nullptr;
}

std::string with_error(const std::string& what, const arv::GErrorSlot& err) {
  return err ? fmt::format("{}: {}", what, err.message()) : what;
}

// The register description's attributes (Aravis' own strings: not freed here).
std::string attribute_text(const char* s) { return s ? s : ""; }
}  // namespace

AravisFeatures::AravisFeatures(ArvDevice* device) : device_(device) {
  chosen_ = resolve_camera_features([this](const std::string& n) { return has(n); });
}

bool AravisFeatures::has(const std::string& feature) const {
  ArvGcFeatureNode* node = feature_node(device_, feature);
  if (!node) return false;
  // A model-generic map declares what this model may lack (pIsImplemented reads the camera).
  arv::GErrorSlot err;
  const gboolean implemented = arv_gc_feature_node_is_implemented(node, err.out());
  return err || implemented;
}

std::string AravisFeatures::type(const std::string& feature) const {
  ArvGcFeatureNode* node = feature_node(device_, feature);
  const char* tag = node ? arv_dom_node_get_node_name(ARV_DOM_NODE(node)) : nullptr;
  return tag ? tag : "";
}

std::vector<std::string> AravisFeatures::entries(const std::string& feature) const {
  std::vector<std::string> out;
  ArvGcFeatureNode* node = feature_node(device_, feature);
  if (!node || !ARV_IS_GC_ENUMERATION(node)) return out;
  guint n = 0;
  arv::GErrorSlot err;
  const char** values = arv_gc_enumeration_dup_available_string_values(ARV_GC_ENUMERATION(node), &n, err.out());
  for (guint i = 0; values && i < n; ++i) out.emplace_back(values[i]);
  g_free(values);  // the array only: its strings are the entries' own
  return out;
}

std::string AravisFeatures::access(const std::string& feature) const {
  return node_access(arv_device_get_feature(device_, feature.c_str()));
}

std::optional<std::pair<double, double>> AravisFeatures::range(const std::string& feature) const {
  const auto r = node_range(arv_device_get_feature(device_, feature.c_str()));
  if (!r) return std::nullopt;
  return std::pair{r->min, r->max};
}

std::vector<std::string> AravisFeatures::all_entries(CameraRole role) const {
  std::vector<std::string> out;
  ArvGcNode* n = node(role);
  if (!n || !ARV_IS_GC_ENUMERATION(n)) return out;
  for (const GSList* e = arv_gc_enumeration_get_entries(ARV_GC_ENUMERATION(n)); e; e = e->next)
    if (ARV_IS_GC_FEATURE_NODE(e->data)) out.emplace_back(arv_gc_feature_node_get_name(ARV_GC_FEATURE_NODE(e->data)));
  return out;
}

namespace {
ArvGcRegisterDescriptionNode* description(ArvDevice* device) {
  ArvGc* gc = arv_device_get_genicam(device);
  ArvDomElement* root = gc ? arv_dom_document_get_document_element(ARV_DOM_DOCUMENT(gc)) : nullptr;
  return root && ARV_IS_GC_REGISTER_DESCRIPTION_NODE(root) ? ARV_GC_REGISTER_DESCRIPTION_NODE(root) : nullptr;
}
}  // namespace

std::string AravisFeatures::vendor() const {
  auto* d = description(device_);
  return d ? attribute_text(arv_gc_register_description_node_get_vendor_name(d)) : "";
}
std::string AravisFeatures::model() const {
  auto* d = description(device_);
  return d ? attribute_text(arv_gc_register_description_node_get_model_name(d)) : "";
}
std::string AravisFeatures::version() const {
  auto* d = description(device_);
  if (!d) return "";
  return fmt::format("{}.{}.{}", arv_gc_register_description_node_get_major_version(d),
                     arv_gc_register_description_node_get_minor_version(d),
                     arv_gc_register_description_node_get_subminor_version(d));
}

std::map<std::string, std::string> AravisFeatures::feature_bag() const {
  std::map<std::string, std::string> bag;
  ArvGc* gc = arv_device_get_genicam(device_);
  ArvDomElement* root = gc ? arv_dom_document_get_document_element(ARV_DOM_DOCUMENT(gc)) : nullptr;
  if (!root) return bag;
  // The nodes that hold a value (not categories, commands, ports, nor the formulas between them);
  // a register itself only where the standard names it a feature (most are the implementation under
  // a feature: ExposureTimeAbsRegister under ExposureTimeAbs).
  static const std::set<std::string> kValueTypes = {"Integer", "Float", "Enumeration", "Boolean", "String"};
  static const std::set<std::string> kRegisterTypes = {"IntReg", "FloatReg", "StringReg", "MaskedIntReg"};
  for (ArvDomNode* n = arv_dom_node_get_first_child(ARV_DOM_NODE(root)); n; n = arv_dom_node_get_next_sibling(n)) {
    if (!ARV_IS_GC_FEATURE_NODE(n)) continue;
    const char* tag = arv_dom_node_get_node_name(n);
    if (!tag) continue;
    auto* feature = ARV_GC_FEATURE_NODE(n);
    const bool standard_register =
        kRegisterTypes.count(tag) && arv_gc_feature_node_get_name_space(feature) == ARV_GC_NAME_SPACE_STANDARD;
    if (!kValueTypes.count(tag) && !standard_register) continue;
    arv::GErrorSlot err;
    if (!arv_gc_feature_node_is_implemented(feature, err.out()) || err) continue;
    if (!arv_gc_feature_node_is_available(feature, err.out()) || err) continue;
    const ArvGcAccessMode access = arv_gc_feature_node_get_actual_access_mode(feature);
    if (access != ARV_GC_ACCESS_MODE_RO && access != ARV_GC_ACCESS_MODE_RW) continue;
    const char* value = arv_gc_feature_node_get_value_as_string(feature, err.out());
    if (err || !value) continue;
    bag[arv_gc_feature_node_get_name(feature)] = value;
  }
  return bag;
}

std::string AravisFeatures::name(CameraRole role) const {
  const auto it = chosen_.find(role);
  return it == chosen_.end() ? "" : it->second;
}

ArvGcNode* AravisFeatures::node(CameraRole role) const {
  const auto it = chosen_.find(role);
  return it == chosen_.end() ? nullptr : arv_device_get_feature(device_, it->second.c_str());
}

namespace {
Status absent(CameraRole role) {
  std::string names;
  for (const auto& r : camera_feature_names())
    if (r.role == role)
      for (const char* n : r.names) names += (names.empty() ? "" : ", ") + std::string(n);
  return Error{fmt::format("it has no {} feature (looked for {})", role_key(role), names)};
}
}  // namespace

Status AravisFeatures::set_entry(CameraRole role, const std::string& value) {
  ArvGcNode* n = node(role);
  if (!n) return absent(role);
  const std::string feature = name(role);
  if (!ARV_IS_GC_ENUMERATION(n)) return Error{fmt::format("{} is not an enumeration ({})", feature, type(feature))};
  arv::GErrorSlot err;
  arv_gc_enumeration_set_string_value(ARV_GC_ENUMERATION(n), value.c_str(), err.out());
  if (err) return Error{with_error(fmt::format("setting {} to {}", feature, value), err)};
  return {};
}

std::optional<double> AravisFeatures::step(CameraRole role) const {
  const RawUnit* raw = raw_unit(name(role));
  if (!raw || !raw->base) return 1.0;
  ArvGcNode* base = arv_device_get_feature(device_, raw->base);
  arv::GErrorSlot err;
  const double v = base && ARV_IS_GC_FLOAT(base)     ? arv_gc_float_get_value(ARV_GC_FLOAT(base), err.out())
                   : base && ARV_IS_GC_INTEGER(base) ? double(arv_gc_integer_get_value(ARV_GC_INTEGER(base), err.out()))
                                                     : NAN;
  if (err || !(v > 0) || !std::isfinite(v)) return std::nullopt;
  return v;
}

Status AravisFeatures::set_number(CameraRole role, double value) {
  ArvGcNode* n = node(role);
  if (!n) return absent(role);
  const std::string feature = name(role);
  // A count of the camera's own steps (ExposureTimeRaw): the value asked, in steps of its base.
  const auto size = step(role);
  if (!size)
    return Error{fmt::format("{} counts in steps of {}, which cannot be read", feature, raw_unit(feature)->base)};
  value /= *size;
  arv::GErrorSlot err;
  if (ARV_IS_GC_FLOAT(n)) {
    // Checked here: Aravis leaves range checks off by default, and a camera may clamp in silence.
    arv::GErrorSlot range;
    const double lo = arv_gc_float_get_min(ARV_GC_FLOAT(n), range.out());
    const double hi = range ? NAN : arv_gc_float_get_max(ARV_GC_FLOAT(n), range.out());
    if (!range && std::isfinite(lo) && std::isfinite(hi) && lo <= hi && (value < lo || value > hi))
      return Error{fmt::format("{} cannot be {:g}: its range is {:g} to {:g}", feature, value, lo, hi)};
    arv_gc_float_set_value(ARV_GC_FLOAT(n), value, err.out());
  } else if (ARV_IS_GC_INTEGER(n)) {
    const auto v = std::int64_t(std::llround(value));
    arv::GErrorSlot range;
    const gint64 lo = arv_gc_integer_get_min(ARV_GC_INTEGER(n), range.out());
    const gint64 hi = range ? 0 : arv_gc_integer_get_max(ARV_GC_INTEGER(n), range.out());
    if (!range && lo <= hi && (v < lo || v > hi))
      return *size == 1 ? Error{fmt::format("{} cannot be {}: its range is {} to {}", feature, v, lo, hi)}
                        : Error{fmt::format("{} cannot be {} ({:g} {} in its steps of {:g}): its range is {} to {} "
                                            "({:g} to {:g} {})",
                                            feature, v, value * *size, role_unit(role, feature), *size, lo, hi,
                                            double(lo) * *size, double(hi) * *size, role_unit(role, feature))};
    arv_gc_integer_set_value(ARV_GC_INTEGER(n), v, err.out());
  } else {
    return Error{fmt::format("{} is not a number ({})", feature, type(feature))};
  }
  if (err) return Error{with_error(fmt::format("setting {} to {:g}", feature, value), err)};
  return {};
}

Status AravisFeatures::set_flag(CameraRole role, bool on) {
  ArvGcNode* n = node(role);
  if (!n) return absent(role);
  const std::string feature = name(role);
  arv::GErrorSlot err;
  if (ARV_IS_GC_BOOLEAN(n))
    arv_gc_boolean_set_value(ARV_GC_BOOLEAN(n), on, err.out());
  else if (ARV_IS_GC_ENUMERATION(n))  // an On/Off mode (Daheng's AcquisitionFrameRateMode)
    arv_gc_enumeration_set_string_value(ARV_GC_ENUMERATION(n), on ? "On" : "Off", err.out());
  else if (ARV_IS_GC_INTEGER(n))
    arv_gc_integer_set_value(ARV_GC_INTEGER(n), on ? 1 : 0, err.out());
  else
    return Error{fmt::format("{} is not a Boolean ({})", feature, type(feature))};
  if (err) return Error{with_error(fmt::format("setting {} to {}", feature, on), err)};
  return {};
}

Status AravisFeatures::execute(CameraRole role) {
  ArvGcNode* n = node(role);
  if (!n) return absent(role);
  const std::string feature = name(role);
  if (!ARV_IS_GC_COMMAND(n)) return Error{fmt::format("{} is not a Command ({})", feature, type(feature))};
  arv::GErrorSlot err;
  arv_gc_command_execute(ARV_GC_COMMAND(n), err.out());
  if (err) return Error{with_error(fmt::format("executing {}", feature), err)};
  return {};
}

std::optional<double> AravisFeatures::number(CameraRole role) const {
  ArvGcNode* n = node(role);
  arv::GErrorSlot err;
  double v = 0;
  if (n && ARV_IS_GC_FLOAT(n))
    v = arv_gc_float_get_value(ARV_GC_FLOAT(n), err.out());
  else if (n && ARV_IS_GC_INTEGER(n))
    v = double(arv_gc_integer_get_value(ARV_GC_INTEGER(n), err.out()));
  else
    return std::nullopt;
  if (err) return std::nullopt;
  const auto size = step(role);
  if (!size) return std::nullopt;
  return v * *size;
}

std::optional<std::string> AravisFeatures::entry(CameraRole role) const {
  ArvGcNode* n = node(role);
  if (!n || !ARV_IS_GC_ENUMERATION(n)) return std::nullopt;
  arv::GErrorSlot err;
  const char* v = arv_gc_enumeration_get_string_value(ARV_GC_ENUMERATION(n), err.out());
  if (err || !v) return std::nullopt;
  return std::string(v);
}

std::optional<std::string> AravisFeatures::text(CameraRole role) const {
  ArvGcNode* n = node(role);
  if (!n || !ARV_IS_GC_FEATURE_NODE(n)) return std::nullopt;
  arv::GErrorSlot err;
  const char* v = arv_gc_feature_node_get_value_as_string(ARV_GC_FEATURE_NODE(n), err.out());
  if (err || !v) return std::nullopt;
  return std::string(v);
}

}  // namespace pvcap
