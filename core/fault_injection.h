#pragma once
// Faults a test can switch on in a real `pvcap session`, to meet the failures a lab meets rarely (a
// consumer thread that falls behind, a queue that fills) through the code that would run on the rig.
// A test sets them in the environment:
//   PVCAP_FAULTS="camera_pipeline.stall_s=1.5,sensel.queue_frames=16"
// app/ reads the variable once (parse_faults) and passes the plan down as a plain value, like any
// other setting; no module below app/ reads the environment. Empty, nothing changes; a process
// given a plan says so once, at warning level, so it is never on unnoticed.
//
// The faults (docs/testing.md lists them with the tests that use them):
//   camera_pipeline.stall_s        the worker of camera `stall_camera` sleeps this long, once,
//   camera_pipeline.stall_camera   (default 0) `stall_after_s` (default 2) after its first frame
//   camera_pipeline.stall_after_s
//   sensel_pipeline.stall_s        the Sensel's worker sleeps this long, once, `stall_after_s`
//   sensel_pipeline.stall_after_s  (default 2) after its first frame
//   sensel.queue_frames            the Sensel driver's frame queue holds this many frames
//   index_writer.stall_s           the index thread sleeps this long, once, `stall_after_s`
//   index_writer.stall_after_s     (default 2) after it starts
//   index_writer.queue_records     the index queue holds this many records
//   index_writer.overflow_memory_records  beyond the queue, this many wait in memory, then on disk
//   encoder.frame_delay_ms         every camera's encoder waits this long before each frame (an
//                                  encoder slower than its camera, whatever the machine)
//   encoder.stall_s                every camera's encoder sleeps this long, once, `stall_after_s`
//   encoder.stall_after_s          (default 2) after its first frame (a disk that held the encoders up:
//                                  their frames go through the spill meanwhile)
//   camera.stop_stall_s            the session's stop waits this long after the first camera's
//                                  stop, before the others' (a camera slow to answer its stop)
//   realign.stall_s                the end-of-session re-mapping waits this long between its steps
//                                  (the frames re-mapped and committed, the samples not yet re-paired)
//   report.stall_s                 the session's report.html waits this long once begun
//   recover.stall_s                `pvcap recover` waits this long after its first step
//   sim.light_off                  letters: the simulated rig's lamps of these names never come on
//   sim.light_lag_s                every simulated lamp reaches its new state this long after its line
// (The last three hold a phase open long enough for a kill to land in it, which a test then proves.)
#include <chrono>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace pvcap {

// A thread that sleeps `seconds`, once, `after_s` after it starts (or its first frame).
struct Stall {
  double seconds = 0;
  double after_s = 2;
};

struct FaultPlan {
  std::optional<Stall> camera_pipeline_stall;
  int stall_camera = 0;  // which camera's worker stalls
  std::optional<Stall> sensel_pipeline_stall;
  std::optional<Stall> index_writer_stall;
  std::optional<std::size_t> sensel_queue_frames, index_queue_records, index_overflow_memory_records;
  std::chrono::milliseconds encoder_frame_delay{0};
  std::optional<Stall> encoder_stall;
  double realign_stall_s = 0, report_stall_s = 0, recover_stall_s = 0;
  double camera_stop_stall_s = 0;  // the session's stop waits this long after the first camera's stop
  std::string sim_light_off;        // the simulator's lamps that never light (sim/lights.h)
  double sim_light_lag_s = 0;       // and how late its lamps follow their lines
  std::string spec;                // as given, for the warning and the log
  bool empty() const { return spec.empty(); }
};

// Reads a PVCAP_FAULTS value. What cannot be read (not name=value, no number, an unknown name) is
// named in `problems` and ignored.
FaultPlan parse_faults(std::string_view spec, std::vector<std::string>& problems);

}  // namespace pvcap
