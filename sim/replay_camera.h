#pragma once
// One camera of a recorded session, re-served over GigE Vision by Aravis' fake-camera engine
// (sim/session_replay.h): the frames it sent then, each with its recorded frame id and device
// timestamp, leaving at its recorded instant (shifted), with the stored mosaic of the frames the
// session kept (read ahead on a thread of its own; a colour store's image is sampled back into the
// sensor's pattern) and the last stored one for the others. Its timestamp latch reads the recorded
// clock. Free-running, the engine is paced to each frame; set to a trigger line, it is triggered as
// each frame falls due.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <thread>

#include <opencv2/core.hpp>

#include "capture/aravis_handles.h"
#include "core/result.h"
#include "core/rig_config.h"
#include "sim/engine_kicker.h"
#include "sim/session_replay.h"

namespace pvcap::sim {

class ReplayCamera {
 public:
  // Serves the recorded camera named like `camera` at `camera.address`; logs each frame it sends to
  // truth_dir/<name>_replay.csv (frame_id, device_ns, due_ns, sent_ns).
  static Result<std::unique_ptr<ReplayCamera>> create(const CameraConfig& camera, std::shared_ptr<SessionReplay> replay,
                                                      const std::filesystem::path& truth_dir);
  ~ReplayCamera();
  ReplayCamera(const ReplayCamera&) = delete;
  ReplayCamera& operator=(const ReplayCamera&) = delete;

 private:
  ReplayCamera() = default;
  static void fill(ArvBuffer* buffer, void* self, guint32 exposure_us, guint32 gain, ArvPixelFormat format);
  void fill_buffer(ArvBuffer* buffer);
  void plan_next_tick();
  // Its trigger line (a session recorded with `trigger: hardware`): one pulse as each recorded frame
  // falls due, 10 ms ahead; the first, before this camera streams, starts it.
  std::int64_t line_pulse(std::int64_t host_ns) const;
  void read_ahead();
  cv::Mat stored_image(std::int64_t sample);

  std::string name_;
  std::string pixel_format_;  // what it sends (a colour store's images are sampled back into it)
  std::shared_ptr<SessionReplay> replay_;
  std::size_t index_ = 0;  // the camera's index in the replay
  // Written by the engine's fill, read by the trigger line's thread.
  std::atomic<std::size_t> next_{0};     // the next frame to send
  std::atomic<bool> streaming_{false};   // the first frame after acquisition start has been sent
  std::atomic<pid_t> engine_thread_{0};  // the engine's thread, known from its first fill
  cv::Mat last_;                         // the last stored mosaic sent (frames the session did not keep reuse it)
  arv::GPtr<ArvGvFakeCamera> fake_;
  std::ofstream log_;
  std::uint64_t logged_ = 0;

  // Read-ahead of stored mosaics, in the order of the frames that have them.
  std::mutex mu_;
  std::condition_variable changed_;
  std::deque<std::pair<std::int64_t, cv::Mat>> ready_;
  // Mosaics sent and no longer needed: freed on the read-ahead's thread, not the engine's (freeing
  // one unmaps its pages, which waits for the process's memory map while the read-ahead decodes
  // into new pages: the frames that brought a new image left 0.3-1.2 ms late).
  std::vector<cv::Mat> retired_;
  bool stop_ = false;
  std::thread reader_;
  std::unique_ptr<EngineKicker> kicker_;  // sim/engine_kicker.h
};

}  // namespace pvcap::sim
