// What the operator is told while recording, once each: frames waiting on disk, and frames or rows
// lost, with what to change. Called by Recording::wait about ten times a second.
#include <thread>

#include <fmt/format.h>

#include "session/camera_pipeline.h"
#include "session/recording.h"
#include "storage/writer/session_writer.h"

namespace pvcap::session {

void Recording::warn_of_losses() {
  // An encoder behind its camera spills frames to disk (nothing lost; it catches up later): say so
  // once. Frames lost because the spill could not keep up either: say so once, with what to change.
  for (std::size_t i = 0; i < cameras_.size(); ++i) {
    if (!warned_spill_[i] && writer_->camera_stats(device_ids_[i]).spilled > 0) {
      warned_spill_[i] = true;
      warn(
          fmt::format("{}: the video encoder is behind; frames wait on disk (the spill) until it catches up. "
                      "Nothing is lost; the session may take longer to close",
                      rig_.cameras[i].name));
    }
    // Frames pvcap itself was too slow to take from the camera: its worker fell behind.
    if (const auto behind = tallies_[i]->buffer_underrun.load(); !warned_behind_[i] && behind > 0) {
      warned_behind_[i] = true;
      warn(
          fmt::format("{}: {} frame{} lost because pvcap did not take {} from the camera in time (the camera's "
                      "stream had no free buffer): this PC is too busy for the rig. Close other programs, or lower "
                      "frame_rate or the resolution in the rig file; raising the camera's buffer_count rides out "
                      "short stalls",
                      rig_.cameras[i].name, behind, behind == 1 ? "" : "s", behind == 1 ? "it" : "them"));
    }
    // Another camera's frames reached this camera's stream: refused, never stored as its pictures.
    if (const auto foreign = tallies_[i]->foreign.load(); !warned_foreign_[i] && foreign > 0) {
      warned_foreign_[i] = true;
      warn(
          fmt::format("{}: {} frame{} of another camera (not the size or pixel format it sends) reached its stream "
                      "and {} refused, not stored as its pictures (frames rows, reason foreign_frame_...): check "
                      "that no other program streams a camera to this PC's ports",
                      rig_.cameras[i].name, foreign, foreign == 1 ? "" : "s", foreign == 1 ? "was" : "were"));
    }
    if (!warned_encoder_[i] && tallies_[i]->encoder_behind.load() > 0) {
      warned_encoder_[i] = true;
      warn(
          fmt::format("{}: frames are being dropped (encoder_behind): neither the video encoder nor its spill to "
                      "disk keeps up. This PC has {} cores for {} camera{} (store.video_mode {}): lower "
                      "store.video_fps in the rig file, record to a faster disk, or on a PC with more cores "
                      "(docs/performance-log.md, Store)",
                      rig_.cameras[i].name, std::thread::hardware_concurrency(), cameras_.size(),
                      cameras_.size() == 1 ? "" : "s", rig_.store.video_mode));
    }
  }
  if (const auto n = sensel_ ? sensel_->queue_overflows() : 0; !warned_sensel_behind_ && n > 0) {
    warned_sensel_behind_ = true;
    warn(
        fmt::format("sensel: {} frame{} lost because pvcap did not take {} from the device in time (its frame "
                    "queue was full): this PC is too busy for the rig; close other programs",
                    n, n == 1 ? "" : "s", n == 1 ? "it" : "them"));
  }
  if (const auto n = writer_->index_records_waited(); !warned_index_behind_ && n > 0) {
    warned_index_behind_ = true;
    warn(
        "session index: behind (the disk or this PC is slow for the rig); its rows wait, in memory and then in "
        "the session's spill folder, and nothing is lost. session.db's index_behind events say how long");
  }
  if (const auto n = writer_->index_records_lost(); !warned_index_ && n > 0) {
    warned_index_ = true;
    warn(
        fmt::format("session index: {} record{} lost ({}): storage failed. session.db's index_overflow events "
                    "say how many of each kind",
                    n, n == 1 ? "" : "s", writer_->index_records_lost_by_kind()));
  }
}

}  // namespace pvcap::session
