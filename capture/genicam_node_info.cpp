#include "capture/genicam_node_info.h"

#include <cmath>

#include "capture/aravis_handles.h"

namespace pvcap {

std::string node_access(ArvGcNode* node) {
  if (!node || !ARV_IS_GC_FEATURE_NODE(node)) return "";
  // Static: read from the map's properties, never from the camera.
  switch (arv_gc_feature_node_get_actual_access_mode(ARV_GC_FEATURE_NODE(node))) {
    case ARV_GC_ACCESS_MODE_RO:
      return "RO";
    case ARV_GC_ACCESS_MODE_WO:
      return "WO";
    case ARV_GC_ACCESS_MODE_RW:
      return "RW";
    default:
      return "";
  }
}

std::optional<FeatureRange> node_range(ArvGcNode* node) {
  arv::GErrorSlot lo_err, hi_err;
  FeatureRange r;
  if (node && ARV_IS_GC_INTEGER(node)) {
    r.min = double(arv_gc_integer_get_min(ARV_GC_INTEGER(node), lo_err.out()));
    r.max = double(arv_gc_integer_get_max(ARV_GC_INTEGER(node), hi_err.out()));
  } else if (node && ARV_IS_GC_FLOAT(node)) {
    r.min = arv_gc_float_get_min(ARV_GC_FLOAT(node), lo_err.out());
    r.max = arv_gc_float_get_max(ARV_GC_FLOAT(node), hi_err.out());
  } else {
    return std::nullopt;
  }
  if (lo_err || hi_err || !std::isfinite(r.min) || !std::isfinite(r.max) || r.min > r.max) return std::nullopt;
  // A node without bounds answers its type's extremes: no range to tell.
  if (std::abs(r.min) >= 9e18 || std::abs(r.max) >= 9e18) return std::nullopt;
  return r;
}

}  // namespace pvcap
