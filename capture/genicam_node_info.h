#pragma once
// What a GenICam feature node says of itself, for the camera check: its access and its range, through
// Aravis' parser, for a node map read offline (capture/genicam_node_map.h) and for a live camera
// (capture/aravis_features.h) alike. Offline, a bound the map keeps in the camera's registers cannot
// be read (no camera to ask): the range is then absent. Internal to capture/: it names Aravis' types.
#include <arv.h>

#include <optional>
#include <string>

namespace pvcap {

struct FeatureRange {
  double min = 0, max = 0;
};

// "RO", "RW" or "WO" (the ImposedAccessMode combined with the registers' AccessMode, as GenApi does);
// "" for a node that is not a feature.
std::string node_access(ArvGcNode* node);
// An Integer's or a Float's bounds, when they can be read (a constant, or a register of a camera
// that answers); nullopt otherwise, and for any other type.
std::optional<FeatureRange> node_range(ArvGcNode* node);

}  // namespace pvcap
