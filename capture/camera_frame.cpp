#include "capture/camera_frame.h"

namespace pvcap {

const char* to_string(FrameStatus status) {
  switch (status) {
    case FrameStatus::Good:
      return "good";
    case FrameStatus::Incomplete:
      return "incomplete";
    case FrameStatus::QueueFull:
      return "queue_full";
  }
  return "?";
}

}  // namespace pvcap
