#pragma once
// Faults a test can switch on in a real `pvcap session`, to meet the failures a
// lab meets rarely (a consumer thread that falls behind, a queue that fills)
// through the code that would run on the rig. Set by the environment:
//   PVCAP_FAULTS="camera_pipeline.stall_s=1.5,camera.queue_frames=4"
// Unset, every lookup is empty and nothing changes. A process that sees the
// variable says so once, at warning level, so it is never on unnoticed.
//
// The faults (docs/testing.md lists them with the tests that use them):
//   camera_pipeline.stall_s        the worker of camera `stall_camera` sleeps this long, once,
//   camera_pipeline.stall_camera   (default 0) `stall_after_s` (default 2) after its first frame
//   camera_pipeline.stall_after_s
//   camera.queue_frames            each camera driver's frame queue holds this many frames
//   sensel_pipeline.stall_s        the Sensel's worker sleeps this long, once, `stall_after_s`
//   sensel_pipeline.stall_after_s  (default 2) after its first frame
//   sensel.queue_frames            the Sensel driver's frame queue holds this many frames
//   index_writer.stall_s           the index thread sleeps this long, once, `stall_after_s`
//   index_writer.stall_after_s     (default 2) after it starts
//   index_writer.queue_records     the index queue holds this many records
#include <optional>
#include <string_view>

namespace pvcap::fault {

// The value of fault `name` in PVCAP_FAULTS, when given.
std::optional<double> value(std::string_view name);

}  // namespace pvcap::fault
