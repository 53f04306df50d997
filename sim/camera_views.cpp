#include "sim/camera_views.h"

#include <array>

namespace pvcap::sim {

namespace {
struct View {
  std::array<double, 3> position_mm, look_at_mm;  // height above the pad as z
  cv::Point2d principal_offset;                   // from the image centre, px at 1920 wide
  std::array<double, 5> distortion;
};
// A mild wide-angle lens each, all a little different, as real units are.
const std::array<View, 4> kDefaultViews = {{
    {{115, 65, 480}, {115, 65, 0}, {6.0, -4.0}, {-0.11, 0.09, 0.0004, -0.0003, -0.02}},
    {{-150, 40, 400}, {110, 65, 0}, {-8.0, 5.0}, {-0.09, 0.07, -0.0002, 0.0005, -0.01}},
    {{380, 95, 400}, {120, 65, 0}, {4.0, 7.0}, {-0.12, 0.10, 0.0003, 0.0002, -0.03}},
    {{115, 330, 380}, {115, 60, 0}, {-5.0, -6.0}, {-0.10, 0.08, -0.0004, -0.0001, -0.02}},
}};
constexpr double kDefaultFocalAt1920 = 1500.0;
}  // namespace

calib::CameraModel sim_camera_model(int index, const SimCameraClock& c, cv::Size configured, cv::Size size) {
  const View& v = kDefaultViews[std::size_t(index) % kDefaultViews.size()];
  const auto pos = c.position_mm.value_or(v.position_mm);
  const auto at = c.look_at_mm.value_or(v.look_at_mm);
  const auto dist = c.distortion.value_or(v.distortion);
  if (configured.width <= 0) configured = size;
  const double focal_configured = c.focal_px.value_or(kDefaultFocalAt1920 * configured.width / 1920.0);
  const double scale = double(size.width) / configured.width;
  const cv::Point2d principal(size.width / 2.0 + v.principal_offset.x * size.width / 1920.0,
                              size.height / 2.0 + v.principal_offset.y * size.width / 1920.0);
  return calib::CameraModel::looking_at(
      size, focal_configured * scale, principal, std::vector<double>(dist.begin(), dist.end()),
      calib::pad_point(pos[0], pos[1], pos[2]), calib::pad_point(at[0], at[1], at[2]));
}

}  // namespace pvcap::sim
