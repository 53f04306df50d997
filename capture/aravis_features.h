#pragma once
// A live camera's features by role (capture/genicam_features.h): each role resolved once against the
// camera's own node map, then set and read back under the name that map uses, whatever its type
// (ExposureTime a Float on SFNC cameras, ExposureTimeRaw an Integer on some; a rate enable a Boolean
// or an Integer). The live camera takes every feature name from here. Errors name the feature, the
// value asked and, for numbers, the camera's range.
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <arv.h>

#include "capture/genicam_features.h"
#include "capture/genicam_node_map.h"
#include "core/result.h"

namespace pvcap {

class AravisFeatures final : public NodeMapView {
 public:
  // `device` outlives this object (the camera's link holds both).
  explicit AravisFeatures(ArvDevice* device);

  // NodeMapView, as the camera answers: a feature it declares but does not implement is absent, an
  // enumeration's entries are those it has now (the Bayer order its sensor has, not every order a
  // vendor's generic map lists).
  bool has(const std::string& feature) const override;
  std::string type(const std::string& feature) const override;
  std::vector<std::string> entries(const std::string& feature) const override;
  std::string access(const std::string& feature) const override;
  std::optional<std::pair<double, double>> range(const std::string& feature) const override;
  std::string vendor() const override;
  std::string model() const override;
  std::string version() const override;

  bool has(CameraRole role) const { return chosen_.count(role) > 0; }
  // The feature chosen for `role` ("" when the camera has none).
  std::string name(CameraRole role) const;
  const std::map<CameraRole, std::string>& chosen() const { return chosen_; }

  // Each fails with the role's feature name when the camera has none.
  Status set_entry(CameraRole role, const std::string& entry);  // an enumeration
  // Numbers are in pvcap's unit for the role (role_unit): a feature in the camera's own steps with a
  // base (ExposureTimeRaw x ExposureTimeBaseAbs) is converted both ways; without one (GainRaw), its counts.
  Status set_number(CameraRole role, double value);             // a Float, or an Integer (rounded)
  Status set_flag(CameraRole role, bool on);  // a Boolean, an Integer 0/1, or an On/Off enumeration
  Status execute(CameraRole role);             // a Command
  std::optional<double> number(CameraRole role) const;
  std::optional<std::string> entry(CameraRole role) const;
  std::optional<std::string> text(CameraRole role) const;  // any feature's value as the map writes it
  // Every readable value the camera has now, by feature name: its whole state for the record (GenApi's
  // "feature bag"); a selector-dependent feature as its selector stands.
  std::map<std::string, std::string> feature_bag() const;
  // Every entry an enumeration role has (all of them, implemented or not), for a loop over selectors.
  std::vector<std::string> all_entries(CameraRole role) const;

 private:
  ArvGcNode* node(CameraRole role) const;
  // One step of `role`'s feature in pvcap's unit: 1 unless it counts in the camera's steps (read from
  // its base each time: a camera may change its base); nullopt when the base cannot be read.
  std::optional<double> step(CameraRole role) const;
  ArvDevice* device_;
  std::map<CameraRole, std::string> chosen_;
};

}  // namespace pvcap
