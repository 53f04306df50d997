// AravisCamera's output lines: the lights the rig file wires to this camera (core/rig_config.h,
// `lights:`), switched through its map's own names (capture/genicam_features.h: line_selector,
// line_source, user_output_selector, user_output_value) and read back.
#include <algorithm>

#include <fmt/format.h>

#include "capture/aravis_camera.h"
#include "capture/aravis_camera_link.h"
#include "capture/aravis_features.h"
#include "capture/genicam_features.h"

namespace pvcap {

namespace {
bool has_entry(const AravisFeatures& f, CameraRole role, const std::string& entry) {
  const auto e = f.entries(f.name(role));
  return std::find(e.begin(), e.end(), entry) != e.end();
}
}  // namespace

Result<std::uint32_t> AravisCamera::set_lights(std::uint32_t on) {
  arv::GPtr<ArvCamera> cam;
  {
    std::lock_guard lock(mu_);
    if (!link_->camera) return Error{fmt::format("{}: not connected: its lights cannot be switched", label())};
    cam.reset(ARV_CAMERA(g_object_ref(link_->camera.get())));
  }
  lights_on_.store(on);  // what a reconnection switches back on (apply_features)
  AravisFeatures f(arv_camera_get_device(cam.get()));
  return apply_lights(f, on);
}

Result<std::uint32_t> AravisCamera::apply_lights(AravisFeatures& f, std::uint32_t on) {
  std::uint32_t read_back = 0;
  int user_output = 0;  // the steady lights take UserOutput1, 2, ... in the rig file's order
  for (std::size_t i = 0; i < config_.lights.size(); ++i) {
    const LightConfig& light = config_.lights[i];
    const bool want = on >> i & 1u;
    const auto failed = [&](const Status& s) {
      return Error{fmt::format("{}: switching light {} on {} {} failed: {}", label(), light.name, light.line,
                               want ? "on" : "off", s.error().message)};
    };
    if (Status s = f.set_entry(CameraRole::LineSelector, light.line); !s.ok()) return failed(s);
    if (light.strobe) {
      const std::string exposure = has_entry(f, CameraRole::LineSource, "ExposureActive") ? "ExposureActive" : "Exposing";
      if (Status s = f.set_entry(CameraRole::LineSource, want ? exposure : "Off"); !s.ok()) return failed(s);
      if (f.entry(CameraRole::LineSource) == exposure) read_back |= 1u << i;
      continue;
    }
    const std::string levels = f.name(CameraRole::UserOutputValue);
    if (levels == "SyncOutLevels" || levels == "SyncOutGpoLevels") {
      // Allied Vision: the line follows its general-purpose output, whose level is a bit of one register.
      if (Status s = f.set_entry(CameraRole::LineSource, "GPO"); !s.ok()) return failed(s);
      const int bit = std::max(0, line_number(light.line) - 1);
      const auto now = std::uint32_t(f.number(CameraRole::UserOutputValue).value_or(0));
      const std::uint32_t next = want ? now | 1u << bit : now & ~(1u << bit);
      if (Status s = f.set_number(CameraRole::UserOutputValue, next); !s.ok()) return failed(s);
      if (std::uint32_t(f.number(CameraRole::UserOutputValue).value_or(0)) >> bit & 1u) read_back |= 1u << i;
      continue;
    }
    const std::string output = fmt::format("UserOutput{}", ++user_output);
    if (Status s = f.set_entry(CameraRole::LineSource, output); !s.ok()) return failed(s);
    if (f.has(CameraRole::UserOutputSelector))
      if (Status s = f.set_entry(CameraRole::UserOutputSelector, output); !s.ok()) return failed(s);
    if (Status s = f.set_flag(CameraRole::UserOutputValue, want); !s.ok()) return failed(s);
    const std::string value = f.text(CameraRole::UserOutputValue).value_or("");  // a Boolean reads "true"
    if (value == "true" || value == "1" || value == "On") read_back |= 1u << i;
  }
  return read_back;
}

}  // namespace pvcap
