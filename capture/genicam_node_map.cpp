#include "capture/genicam_node_map.h"

#include <arv.h>

#include <algorithm>
#include <iterator>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "capture/aravis_handles.h"
#include "capture/genicam_features.h"
#include "capture/genicam_node_info.h"

namespace pvcap {

struct GenicamNodeMap::Impl {
  arv::GPtr<ArvGc> gc;
  ArvGcRegisterDescriptionNode* description = nullptr;  // owned by gc
};

GenicamNodeMap::GenicamNodeMap(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
GenicamNodeMap::~GenicamNodeMap() = default;
GenicamNodeMap::GenicamNodeMap(GenicamNodeMap&&) noexcept = default;
GenicamNodeMap& GenicamNodeMap::operator=(GenicamNodeMap&&) noexcept = default;

Result<GenicamNodeMap> GenicamNodeMap::parse(const std::string& xml) {
  // Aravis parses without a device: names, types and entries are in the XML; registers are not read.
  auto impl = std::make_unique<Impl>();
  impl->gc.reset(arv_gc_new(nullptr, xml.data(), xml.size()));
  if (!impl->gc) return Error{"not a GenICam node map (the XML could not be parsed)"};
  ArvDomElement* root = arv_dom_document_get_document_element(ARV_DOM_DOCUMENT(impl->gc.get()));
  if (!root || !ARV_IS_GC_REGISTER_DESCRIPTION_NODE(root))
    return Error{"not a GenICam node map (no RegisterDescription at its root)"};
  impl->description = ARV_GC_REGISTER_DESCRIPTION_NODE(root);
  return GenicamNodeMap(std::move(impl));
}

bool GenicamNodeMap::has(const std::string& feature) const {
  ArvGcNode* node = arv_gc_get_node(impl_->gc.get(), feature.c_str());
  return node && ARV_IS_GC_FEATURE_NODE(node);
}

std::string GenicamNodeMap::type(const std::string& feature) const {
  ArvGcNode* node = arv_gc_get_node(impl_->gc.get(), feature.c_str());
  if (!node) return "";
  // The XML element's own name (Command, Integer, Float, Enumeration, Boolean, IntReg, Converter...).
  const char* tag = arv_dom_node_get_node_name(ARV_DOM_NODE(node));
  return tag ? tag : "";
}

std::vector<std::string> GenicamNodeMap::entries(const std::string& feature) const {
  std::vector<std::string> out;
  ArvGcNode* node = arv_gc_get_node(impl_->gc.get(), feature.c_str());
  if (!node || !ARV_IS_GC_ENUMERATION(node)) return out;
  for (const GSList* e = arv_gc_enumeration_get_entries(ARV_GC_ENUMERATION(node)); e; e = e->next)
    if (ARV_IS_GC_FEATURE_NODE(e->data)) out.emplace_back(arv_gc_feature_node_get_name(ARV_GC_FEATURE_NODE(e->data)));
  return out;
}

std::string GenicamNodeMap::access(const std::string& feature) const {
  return node_access(arv_gc_get_node(impl_->gc.get(), feature.c_str()));
}

std::optional<std::pair<double, double>> GenicamNodeMap::range(const std::string& feature) const {
  const auto r = node_range(arv_gc_get_node(impl_->gc.get(), feature.c_str()));
  if (!r) return std::nullopt;
  return std::pair{r->min, r->max};
}

namespace {
// Aravis hands out its own copy of these attributes (transfer none, though typed char*): never freed here.
std::string attribute(const char* s) { return s ? s : ""; }
}  // namespace

std::string GenicamNodeMap::vendor() const {
  return attribute(arv_gc_register_description_node_get_vendor_name(impl_->description));
}
std::string GenicamNodeMap::model() const {
  return attribute(arv_gc_register_description_node_get_model_name(impl_->description));
}
std::string GenicamNodeMap::version() const {
  auto* d = impl_->description;
  return fmt::format("{}.{}.{}", arv_gc_register_description_node_get_major_version(d),
                     arv_gc_register_description_node_get_minor_version(d),
                     arv_gc_register_description_node_get_subminor_version(d));
}

namespace {
bool among(const std::vector<std::string>& list, const std::string& v) {
  return std::find(list.begin(), list.end(), v) != list.end();
}
}  // namespace

NodeMapCheck check_node_map(const NodeMapView& map, const CameraConfig& camera) {
  NodeMapCheck out;
  out.vendor = map.vendor();
  out.model = map.model();
  out.version = map.version();
  const auto chosen = resolve_camera_features([&](const std::string& name) { return map.has(name); });
  for (const auto& r : camera_feature_names()) {
    const auto it = chosen.find(r.role);
    if (it == chosen.end()) continue;
    out.features.push_back({r.key, it->second, map.type(it->second), map.entries(it->second), map.access(it->second),
                            map.range(it->second)});
  }
  const auto have = [&](CameraRole role) { return chosen.count(role) > 0; };
  for (CameraRole role : {CameraRole::PixelFormat, CameraRole::Width, CameraRole::Height, CameraRole::ExposureTime})
    if (!have(role))
      out.missing.push_back(role == CameraRole::ExposureTime && map.has("ExposureTimeRaw")
                                ? "no exposure_time feature in microseconds: ExposureTimeRaw counts in the camera's "
                                  "own steps, and the map has no ExposureTimeBaseAbs to say how long one is"
                                : fmt::format("no {} feature", role_key(role)));
  if (have(CameraRole::PixelFormat)) {
    const auto formats = map.entries(chosen.at(CameraRole::PixelFormat));
    if (!among(formats, camera.pixel_format))
      out.missing.push_back(
          fmt::format("pixel format {} is not among its {}", camera.pixel_format, fmt::join(formats, ", ")));
  }
  // A trigger needs its mode and a source of that name; software triggers, the command too.
  if (camera.trigger != TriggerMode::FreeRun) {
    const std::string source = camera.trigger == TriggerMode::Software ? "Software" : camera.trigger_source;
    if (!have(CameraRole::TriggerMode) || !have(CameraRole::TriggerSource))
      out.missing.push_back(
          fmt::format("no trigger_mode or trigger_source feature: it cannot take the trigger {}", source));
    else if (const auto sources = map.entries(chosen.at(CameraRole::TriggerSource)); !among(sources, source))
      out.missing.push_back(fmt::format("trigger source {} is not among its {}", source, fmt::join(sources, ", ")));
    if (camera.trigger == TriggerMode::Software && !map.has("TriggerSoftware"))
      out.missing.push_back("no TriggerSoftware command: it cannot be triggered by software");
  }
  out.clock = have(CameraRole::TimestampLatch) ? "latch" : "arrival";
  if (out.clock == "arrival")
    out.warnings.push_back(
        "no timestamp latch: pvcap would put its frames on the host clock by their arrival times (the weaker clock)");
  if (camera.trigger == TriggerMode::FreeRun) {
    if (!have(CameraRole::FrameRate))
      out.warnings.push_back(
          fmt::format("no frame rate feature: it free-runs at its own rate, which may not be the rig's {:g} Hz",
                      camera.frame_rate));
    else if (const auto r = map.range(chosen.at(CameraRole::FrameRate)); r && camera.frame_rate > r->second * 1.001)
      out.missing.push_back(fmt::format("a frame rate of {:g} Hz: its {} goes up to {:g}", camera.frame_rate,
                                        chosen.at(CameraRole::FrameRate), r->second));
    else if (!have(CameraRole::FrameRateEnable) && out.vendor.find("FLIR") != std::string::npos)
      out.warnings.push_back("no frame rate enable: a FLIR camera may ignore the rate set");
    if (!have(CameraRole::TriggerSource)) out.warnings.push_back("no trigger source: no hardware or software trigger");
  }
  if (have(CameraRole::Gain))
    if (const RawUnit* raw = raw_unit(chosen.at(CameraRole::Gain)); raw && !raw->base)
      out.warnings.push_back(
          fmt::format("its gain ({}) is in the camera's own counts, not dB: the rig file's gain "
                      "and the stored gain are such counts",
                      raw->feature));
  // The lights it drives: each on one of its output lines, from a source that switches it as the rig
  // file asks (a user output held on or off, or the exposure itself).
  for (const LightConfig& light : camera.lights) {
    const std::string what = fmt::format("light {} on {} ({})", light.name, light.line,
                                         light.strobe ? "strobed with each exposure" : "steady");
    if (!have(CameraRole::LineSelector) || !have(CameraRole::LineSource)) {
      out.missing.push_back(
          fmt::format("{}: it has no output lines to drive it (no line_selector and line_source "
                      "feature: LineSelector/LineSource, SyncOutSelector/SyncOutSource)",
                      what));
      continue;
    }
    auto lines = map.entries(chosen.at(CameraRole::LineSelector));
    std::sort(lines.begin(), lines.end());  // maps list them in any order; the message in one
    if (!among(lines, light.line)) {
      out.missing.push_back(
          fmt::format("{}: {} is not among its lines ({})", what, light.line, fmt::join(lines, ", ")));
      continue;
    }
    const auto sources = map.entries(chosen.at(CameraRole::LineSource));
    const auto offered = [&](std::initializer_list<const char*> names) {
      for (const char* n : names)
        if (among(sources, n)) return true;
      return false;
    };
    if (light.strobe && !offered({"ExposureActive", "Exposing"}))
      out.missing.push_back(fmt::format("{}: its {} has no exposure source (ExposureActive, Exposing) among {}", what,
                                        chosen.at(CameraRole::LineSource), fmt::join(sources, ", ")));
    if (!light.strobe) {
      const bool user_output = std::any_of(sources.begin(), sources.end(),
                                           [](const std::string& s) { return s.rfind("UserOutput", 0) == 0; });
      if ((!user_output && !among(sources, "GPO")) || !have(CameraRole::UserOutputValue))
        out.missing.push_back(fmt::format(
            "{}: it cannot hold a line on or off (no UserOutput or GPO source among its {}, or no user_output_value "
            "feature)",
            what, chosen.at(CameraRole::LineSource)));
    }
  }
  out.ptp = have(CameraRole::PtpEnable);
  out.chunks = have(CameraRole::ChunkModeActive);
  return out;
}

nlohmann::json node_map_check_json(const NodeMapCheck& c) {
  nlohmann::json features = nlohmann::json::object(), types = nlohmann::json::object(),
                 roles = nlohmann::json::object();
  for (const auto& f : c.features) {
    features[f.role] = f.name, types[f.role] = f.type;
    nlohmann::json role = {{"name", f.name}, {"type", f.type}, {"access", f.access}};
    if (!f.entries.empty()) role["entries"] = f.entries;
    if (f.range) role["range"] = {f.range->first, f.range->second};
    roles[f.role] = role;
  }
  return {{"usable", c.usable()}, {"clock", c.clock},     {"features", features},   {"types", types},
          {"roles", roles},       {"missing", c.missing}, {"warnings", c.warnings}, {"ptp", c.ptp},
          {"chunks", c.chunks},   {"vendor", c.vendor},   {"model", c.model},       {"version", c.version}};
}

std::string describe_node_map_check(const NodeMapCheck& c, const std::string& file) {
  std::string out;
  auto to = std::back_inserter(out);
  fmt::format_to(to, "{}: {} {} (node map version {})\n", file, c.vendor, c.model, c.version);
  for (const auto& f : c.features) {
    std::string entries;
    if (!f.entries.empty())
      entries = f.entries.size() <= 12 ? fmt::format(": {}", fmt::join(f.entries, ", "))
                                       : fmt::format(": {} entries", f.entries.size());
    else if (f.range)
      entries = fmt::format(": {:.10g} to {:.10g}", f.range->first, f.range->second);
    else if (f.type == "Integer" || f.type == "Float")
      entries = ": range from the camera";
    fmt::format_to(to, "  {:<26} {:<30} {:<2} {}{}\n", f.role, f.name, f.access, f.type, entries);
  }
  fmt::format_to(to, "clock: {}\nPTP: {}\nchunk data: {}\n",
                 c.clock == "latch" ? "latch (the camera's own, latched)" : "arrival (host arrival times)",
                 c.ptp ? "yes" : "no", c.chunks ? "yes" : "no");
  for (const auto& w : c.warnings) fmt::format_to(to, "warning: {}\n", w);
  for (const auto& m : c.missing) fmt::format_to(to, "missing: {}\n", m);
  fmt::format_to(to, "{}\n", c.usable() ? "usable" : "NOT usable");
  return out;
}

}  // namespace pvcap
