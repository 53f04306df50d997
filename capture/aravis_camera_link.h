#pragma once
// The connection behind an AravisCamera (Aravis' camera, its stream, the control-lost signal):
// private to capture/aravis_camera*.cpp, so the class's own header carries no Aravis or GLib type.
#include <memory>

#include "capture/aravis_camera.h"
#include "capture/aravis_handles.h"
#include "capture/aravis_stream.h"

namespace pvcap {

struct AravisCamera::Link {
  arv::GPtr<ArvCamera> camera;
  std::shared_ptr<AravisStream> stream;
  gulong control_lost_id = 0;
  bool acquiring = false;  // told AcquisitionStart, and counted among the process's acquiring cameras
  // GLib's "control-lost" signal, on Aravis' heartbeat thread: wakes the control loop.
  static void on_control_lost(ArvGvDevice*, void* self) {
    auto* cam = static_cast<AravisCamera*>(self);
    cam->control_lost_.store(true);
    cam->wake_.notify_all();
  }
};

}  // namespace pvcap
