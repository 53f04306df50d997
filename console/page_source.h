#pragma once
// What the session's pages read from the running recording and send to it. The pages see the
// recording only through this (console/recording_env.h adapts session::Recording), so they are
// served, tested and fuzzed without devices or a store.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>

#include <opencv2/core.hpp>

#include "session/recording_status.h"
#include "storage/index/records.h"

namespace pvcap::console {

class PageSource {
 public:
  virtual ~PageSource() = default;
  virtual session::RecordingStatus status() const = 0;
  virtual std::size_t camera_count() const = 0;
  // A camera's latest preview (the thumbnail, or `full` the whole frame) and when it arrived; an
  // empty image when there is none (or no such camera).
  virtual std::pair<cv::Mat, std::int64_t> preview(std::size_t camera, bool full) const = 0;
  virtual std::optional<session::PressureSnapshot> pressure_now() const = 0;
  // Committed to the store before it returns true (the page is answered only then).
  virtual bool post(ProtocolEventRecord event) = 0;
  // Asks the recording to stop (the remote-control API's stop); it ends as Ctrl-C ends it.
  virtual void request_stop(std::string reason) = 0;
};

}  // namespace pvcap::console
