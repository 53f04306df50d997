#pragma once
// A recording's timeline: one clock model per stream, the grouper, the 15 Hz
// subsampler and the pressure aligner, shared by the camera and Sensel workers.
//
// Each worker maps its own frames (its clock model is touched by no other thread)
// and hands them in; the shared stages run under one short lock. Results leave in
// two ways: every camera frame gets a decision (kept for a sample, or why not) that
// its camera's worker collects, and finished samples (cameras + paired pressure)
// go to `on_sample`, called outside the lock. Nothing here waits on I/O.
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "core/time.h"
#include "sync/clock_model.h"
#include "sync/timeline.h"

namespace pvcap::sync {

struct TimelineConfig {
  int cameras = 0;
  double camera_hz = 60;                                 // nominal; the grouping limit is half its period
  double sample_hz = 15;                                 // the dataset's grid
  std::int64_t anchor_ns = 0;                            // the grid's tick 0 (session start, host time)
  std::int64_t group_wait_ns = 250'000'000;              // how long a silent camera may hold up grouping
  std::int64_t pressure_window_ns = 60'000'000;          // late / reordered pressure frames within this are handled
  std::int64_t pressure_max_offset_ns = 20'000'000;      // farther than this from a sample: unpaired
  std::vector<std::int64_t> camera_latency_ns;           // known constant latencies (rig file)
  std::vector<std::int64_t> camera_stamp_to_instant_ns;  // each camera's stamp to the middle of its exposure
  std::int64_t pressure_latency_ns = 0;
  bool has_pressure = true;  // without a Sensel, samples are finished without waiting for pressure
  std::int64_t pressure_give_up_ns = 1'000'000'000;  // a silent Sensel holds samples back at most this long
};

struct SampleOut {
  std::uint64_t index = 0;  // 0, 1, 2... in time order
  std::int64_t tick = 0, tick_ns = 0;
  Group group;  // the camera frames (stream = camera index)
  PressureAligner::Pairing pressure;
};

struct FrameDecision {
  std::uint32_t connection = 0;
  std::uint64_t sequence = 0;
  bool kept = false;
  std::string reason;  // when not kept
};

// A clock model's state at one moment, stored so alignment can be redone offline.
struct ClockSnapshot {
  int stream = 0;  // camera index, or -1 for the pressure stream
  std::int64_t host_ns = 0;
  int segment = 0;
  ClockFit fit;                 // host = fit.map(device) - latency_ns
  std::int64_t latency_ns = 0;  // 0 when probes define the mapping
  bool probed = false;
  std::size_t pairs = 0, envelope_points = 0;
  std::int64_t residual_p50_ns = 0, residual_p99_ns = 0;  // arrivals above the line since the last snapshot
};

class SessionTimeline {
 public:
  SessionTimeline(TimelineConfig config, std::function<void(SampleOut)> on_sample,
                  std::function<void(ClockSnapshot)> on_clock);

  // The drivers' two clocks meet here, so they are typed: a device's own time (DeviceNs) and
  // CLOCK_MONOTONIC (HostNs) cannot be passed for one another.
  // From camera `c`'s worker: maps the frame, hands it to the grouper, returns its mapped time.
  HostNs camera_frame(int c, std::uint32_t connection, std::uint64_t sequence, DeviceNs device, HostNs arrival);
  // From camera `c`'s worker: its clock read at a host instant in [host_lo, host_hi] (a
  // timestamp-latch probe).
  void camera_probe(int c, DeviceNs device, HostNs host_lo, HostNs host_hi);
  // Decisions for camera `c`'s frames made since the last call.
  std::vector<FrameDecision> take_decisions(int c);
  // From the Sensel's worker.
  HostNs pressure_frame(std::uint32_t connection, std::uint64_t sequence, DeviceNs device, HostNs arrival);
  // At the end: decides everything pending.
  void flush();
  // While the session stops: decides what no camera frame can still join, every instant before
  // `before` (the cameras were told to stop; a frame exposed that long ago that has not come will
  // not), so that the workers hand their frames on without waiting for the slowest camera's stop.
  void settle(HostNs before);

  struct Counts {
    std::uint64_t groups_complete = 0, groups_incomplete = 0, late_camera_frames = 0, missed_ticks = 0, samples = 0;
    std::map<std::string, std::uint64_t> unpaired;
    std::vector<int> clock_resets;  // per camera, then the pressure stream last
  };
  Counts counts() const;

  // Hands every stream's current fit to `on_clock` (at the stream's last arrival), so the store
  // holds each segment's final fit: a re-mapping from the store (session/realign.h) needs nothing
  // else. Call once the streams are stopped.
  void final_snapshots();

 private:
  struct Stream {
    ClockModel model;
    std::vector<std::int64_t> residuals;  // since the last snapshot
    std::int64_t next_snapshot_ns = 0;
    std::int64_t last_arrival_ns = 0;
    bool last_probed = false;  // the fit was the probes' before the latest pair
    int resets = 0;
  };
  std::int64_t map(Stream& s, int id, std::int64_t device_ns, std::int64_t arrival_ns);
  // One snapshot; `current`: of the model's current segment (with its pair counts and residuals).
  void emit(Stream& s, int id, std::int64_t host_ns, int segment, const ClockModel::Segment& seg, bool probed,
            bool current);
  // Under mu_; `settled_before`: as settle().
  void advance(std::vector<SampleOut>& done, bool flush, std::int64_t settled_before = INT64_MIN);
  void decide(const Group& g, bool kept, const char* reason);

  TimelineConfig config_;
  std::function<void(SampleOut)> on_sample_;
  std::function<void(ClockSnapshot)> on_clock_;
  std::vector<Stream> cameras_;
  Stream pressure_;

  mutable std::mutex mu_;
  Grouper grouper_;
  Subsampler subsampler_;
  PressureAligner aligner_;
  std::vector<std::vector<FrameDecision>> decisions_;
  std::map<std::uint64_t, SampleOut> awaiting_pressure_;
  std::uint64_t next_sample_ = 0;
  std::int64_t newest_camera_ns_ = INT64_MIN;
};

}  // namespace pvcap::sync
