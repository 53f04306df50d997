#pragma once
// A camera's GenICam node map read offline (its XML, as a camera hands it out or `pvcap devices
// --dump-node-map` writes it), through Aravis' own GenICam parser: which features it declares,
// their types and an enumeration's entries. Register values need the camera: none are read here.
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "core/result.h"
#include "core/rig_config.h"

namespace pvcap {

// What a check needs of a node map: offline from its XML (GenicamNodeMap), live from the camera
// itself (capture/aravis_features.h), which also knows what its model implements.
class NodeMapView {
 public:
  virtual ~NodeMapView() = default;
  virtual bool has(const std::string& feature) const = 0;
  // "Command", "Integer", "Float", "Enumeration", "Boolean", "String", "Register", ... ("" when absent).
  virtual std::string type(const std::string& feature) const = 0;
  // An enumeration's entries by name (empty for any other feature).
  virtual std::vector<std::string> entries(const std::string& feature) const = 0;
  // "RO", "RW" or "WO" ("" when absent).
  virtual std::string access(const std::string& feature) const = 0;
  // A number's bounds, where they can be read (offline: those the map states, not those in the
  // camera's registers); nullopt otherwise.
  virtual std::optional<std::pair<double, double>> range(const std::string& feature) const = 0;
  // The map's own RegisterDescription attributes: VendorName, ModelName, its version (major.minor.subminor).
  virtual std::string vendor() const = 0;
  virtual std::string model() const = 0;
  virtual std::string version() const = 0;
};

class GenicamNodeMap final : public NodeMapView {
 public:
  // An Error when the bytes are not a GenICam node map (no RegisterDescription, nothing parsed).
  static Result<GenicamNodeMap> parse(const std::string& xml);
  ~GenicamNodeMap();
  GenicamNodeMap(GenicamNodeMap&&) noexcept;
  GenicamNodeMap& operator=(GenicamNodeMap&&) noexcept;

  bool has(const std::string& feature) const override;
  std::string type(const std::string& feature) const override;
  std::vector<std::string> entries(const std::string& feature) const override;
  std::string access(const std::string& feature) const override;
  std::optional<std::pair<double, double>> range(const std::string& feature) const override;
  std::string vendor() const override;
  std::string model() const override;
  std::string version() const override;

 private:
  struct Impl;
  explicit GenicamNodeMap(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// What `pvcap camera check` finds in a node map, for a camera configured as `camera` (its pixel
// format, its trigger and source; the defaults: BayerRG8, free-running). The live camera runs the
// same check on what it answers, before any recording.
struct NodeMapCheck {
  std::string vendor, model, version;
  struct Feature {
    std::string role, name, type;
    std::vector<std::string> entries;  // an enumeration's
    std::string access;                // RO, RW, WO
    std::optional<std::pair<double, double>> range;  // a number's, where it can be read
  };
  std::vector<Feature> features;  // every role found, in the table's order
  std::string clock;              // "latch" (the camera's clock, latched) or "arrival" (host arrival times)
  bool ptp = false, chunks = false;
  std::vector<std::string> missing;   // what pvcap needs and the map lacks: the camera is not usable
  std::vector<std::string> warnings;  // what it would do without (the weaker clock, a rate it cannot set)
  bool usable() const { return missing.empty(); }
};
NodeMapCheck check_node_map(const NodeMapView& map, const CameraConfig& camera);
// The check as `pvcap camera check` shows it: each role found (name, access, type, entries or range),
// the clock, PTP, chunk data, warnings, what is missing and the verdict; and the same as JSON.
std::string describe_node_map_check(const NodeMapCheck& c, const std::string& file);
nlohmann::json node_map_check_json(const NodeMapCheck& c);

}  // namespace pvcap
