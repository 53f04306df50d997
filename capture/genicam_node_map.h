#pragma once
// A camera's GenICam node map read offline (its XML, as a camera hands it out or `pvcap devices
// --dump-node-map` writes it), through Aravis' own GenICam parser: which features it declares,
// their types and an enumeration's entries. Register values need the camera: none are read here.
#include <memory>
#include <string>
#include <vector>

#include "core/result.h"

namespace pvcap {

class GenicamNodeMap {
 public:
  // An Error when the bytes are not a GenICam node map (no RegisterDescription, nothing parsed).
  static Result<GenicamNodeMap> parse(const std::string& xml);
  ~GenicamNodeMap();
  GenicamNodeMap(GenicamNodeMap&&) noexcept;
  GenicamNodeMap& operator=(GenicamNodeMap&&) noexcept;

  bool has(const std::string& feature) const;
  // "Command", "Integer", "Float", "Enumeration", "Boolean", "String", "Register", ... ("" when absent).
  std::string type(const std::string& feature) const;
  // An enumeration's entries by name (empty for any other feature).
  std::vector<std::string> entries(const std::string& feature) const;
  // The map's own RegisterDescription attributes: VendorName, ModelName, its version (major.minor.subminor).
  std::string vendor() const;
  std::string model() const;
  std::string version() const;

 private:
  struct Impl;
  explicit GenicamNodeMap(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// What `pvcap camera check` finds in a node map, for a camera configured with `pixel_format`.
struct NodeMapCheck {
  std::string vendor, model, version;
  struct Feature {
    std::string role, name, type;
    std::vector<std::string> entries;  // an enumeration's
  };
  std::vector<Feature> features;  // every role found, in the table's order
  std::string clock;              // "latch" (the camera's clock, latched) or "arrival" (host arrival times)
  bool ptp = false, chunks = false;
  std::vector<std::string> missing;   // what pvcap needs and the map lacks: the camera is not usable
  std::vector<std::string> warnings;  // what it would do without (the weaker clock, a rate it cannot set)
  bool usable() const { return missing.empty(); }
};
NodeMapCheck check_node_map(const GenicamNodeMap& map, const std::string& pixel_format);

}  // namespace pvcap
