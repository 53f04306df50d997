#pragma once
// The last step of a recording, and of recovering one: every frame re-mapped with its stream's
// final clock fit (the online fit each frame met was fitted on less), then every sample's instant
// and pressure pairing recomputed. Which frames are in the videos was decided online and stays;
// but a group formed on a poor early fit (a loaded start) can hold a frame that the final fits put
// a frame period from the others. Each group is held to the live grouper's rule again: the most
// frames that lie within its limit stay (ties: the set nearest the sample's tick), the others leave
// the sample and keep their place in the video with the reason `outside_its_group`.
//
// The fits come from the store (clock_models: a segment begins at its first row and is fitted as
// its last row says; the recorder writes each segment's final fit when it ends), so a session
// killed mid-way is re-mapped by `pvcap recover` exactly as a finished one is at its close.
//
// Committed in steps: the frames' new instants in one transaction, then the samples in steps of
// `samples_per_step`, each step said. The event `realign_started` is committed first and
// `realign_done` with the last step; an interruption in between leaves the first without the
// second, and `pvcap recover` runs it again (the same fits give the same result).
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include "core/result.h"
#include "storage/index/session_index.h"

namespace pvcap {

struct RealignOptions {
  std::int64_t max_offset_ns = 20'000'000;  // farther than this from a sample: no pressure paired
  std::size_t samples_per_step = 2000;
  std::function<void(const std::string&)> progress;  // a line per step
  // A group's span at most this: the live grouper's limit, half the fastest camera's period
  // (sync::Grouper::limit_for). 0: from the rig the session recorded.
  std::int64_t group_limit_ns = 0;
};

struct RealignResult {
  std::size_t samples = 0;               // re-paired
  std::size_t segments = 0;              // clock segments applied, over all streams
  std::size_t frames_out_of_groups = 0;  // camera frames the final fits put outside their group
  // Per camera that lost any: its name, the frames that left, and how many its samples held before.
  struct CameraLeft {
    std::string camera;
    std::size_t left = 0, in_samples = 0;
  };
  std::vector<CameraLeft> left_by_camera;
  // The cameras of left_by_camera that lost more than `share` of their sampled frames: a sign that
  // its clock fit and the others' disagree (the report's sync self-check measures it), said in one line.
  std::string cameras_that_left(double share) const;
  static constexpr double kManyLeft = 0.02;  // a share worth a warning: more than a stray frame at the ends
  std::int64_t group_limit_ns = 0;           // the grouping rule the groups were held to
  // What a session's end and `pvcap recover` say when a camera lost more than kManyLeft: one line,
  // empty when none did.
  std::string many_left_warning() const;
  double seconds = 0;
};

RealignResult realign(SessionIndex& index, const RealignOptions& options = {});

// The store's re-mapping was started and not finished (interrupted), or a session recorded with
// the re-mapping in steps never got to it (killed while recording).
bool realign_pending(SessionIndex& index);

// `pvcap recover`'s last step: re-maps the session in `dir` when it was interrupted (`interrupted`:
// recover found it so) or its re-mapping is pending; nullopt when neither.
Result<std::optional<RealignResult>> realign_if_needed(const std::filesystem::path& dir, bool interrupted,
                                                       const std::function<void(const std::string&)>& progress);

// `pvcap recover`: storage's recover_session (videos closed, losses marked; storage/writer/recover.h), then
// the timeline re-mapped with the stored clock fits as a finished session's was. What was done, one
// line each (none: the session had ended cleanly).
Result<std::vector<std::string>> recover_and_realign(const std::filesystem::path& dir,
                                                     const std::function<void(const std::string&)>& progress);

}  // namespace pvcap
