#pragma once
// From per-stream frames on one clock (mapped host time) to dataset samples:
//
//   Grouper         one frame per camera for the same instant -> groups
//   Subsampler      the group nearest each tick of a fixed grid -> samples
//   PressureAligner each sample's nearest pressure frame, with its two neighbours
//
// All three are streaming, deterministic and free of I/O: they take frames in
// arrival order and emit results once nothing that may still arrive could change
// them. Memory is bounded by their windows, never by the session length.
#include <array>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace pvcap::sync {

// A frame as the timeline sees it: which stream, which frame (the stream's own
// sequence), and its mapped time.
struct FrameRef {
  int stream = 0;
  std::uint64_t sequence = 0;
  std::int64_t t_ns = 0;         // mapped host time
  std::uint32_t connection = 0;  // sequences restart with each connection of a device
};

struct Group {
  std::vector<std::optional<FrameRef>> members;  // one slot per camera; empty = no frame for this instant
  std::int64_t t_ns = 0;                         // mean of the members' times
  std::int64_t span_ns = 0;                      // latest minus earliest member
  bool complete() const {
    for (const auto& m : members)
      if (!m) return false;
    return true;
  }
};

// Groups camera frames by instant. The earliest pending frame anchors a group; every
// other camera contributes its earliest pending frame if that lies within `limit_ns`
// (half a frame period) of the anchor and is not nearer the anchor's next frame (so each
// frame goes to the instant it is closest to). Frames are used once,
// groups come out in time order. A group is decided once every camera has shown a frame
// past anchor + limit, or the `horizon` (latest mapped time minus `wait_ns`) has passed
// it, so a silent camera delays nothing by more than `wait_ns`.
class Grouper {
 public:
  // The limit for cameras at `camera_hz`: half a frame period.
  static std::int64_t limit_for(double camera_hz) { return std::int64_t(0.5e9 / camera_hz); }
  Grouper(int cameras, std::int64_t limit_ns, std::int64_t wait_ns);
  // Frames of one camera must come in time order; frames of different cameras interleave freely.
  // False (and counted as late) for a frame whose instant is already decided.
  bool add(const FrameRef& frame);
  // Groups decided so far (each returned once). `flush` decides everything pending (at the end);
  // `settled_before`: every group whose window closes before that time is decided too (no frame
  // for it can still come: the cameras have stopped).
  std::vector<Group> take(bool flush = false, std::int64_t settled_before = INT64_MIN);
  std::int64_t limit_ns() const { return limit_ns_; }

  std::uint64_t complete_groups() const { return complete_; }
  std::uint64_t incomplete_groups() const { return incomplete_; }
  std::uint64_t late_frames() const { return late_; }  // came after their instant was decided

 private:
  bool decide(bool flush, std::int64_t settled_before);
  std::vector<std::deque<FrameRef>> pending_;
  std::vector<std::int64_t> latest_;  // newest time seen per camera
  std::int64_t decided_until_ = INT64_MIN;
  std::int64_t limit_ns_, wait_ns_;
  std::vector<Group> out_;
  std::uint64_t complete_ = 0, incomplete_ = 0, late_ = 0;
};

// The sample grids of all sessions at one rate share a lattice of the host clock: instants k / grid_hz
// seconds from its zero. A session anchors its grid at the lattice point at or before its start, so two
// sessions' ticks differ by whole periods: a session re-served through the simulated devices at a shift
// of whole periods (sim/session_replay.h) is sampled at the same instants when it is recorded again.
std::int64_t grid_lattice_floor(std::int64_t t_ns, double grid_hz);

// Picks, for each tick of a grid anchored at `anchor_ns` (tick k at anchor + k * period,
// computed, never accumulated, so it cannot drift), the group whose time is nearest the
// tick, among groups within half a grid period. A tick no group came near is reported as
// missed.
class Subsampler {
 public:
  Subsampler(std::int64_t anchor_ns, double grid_hz);
  struct Sample {
    std::int64_t tick = 0;
    std::int64_t tick_ns = 0;
    Group group;
  };
  // Groups in time order; returns samples whose tick can no longer get a nearer group.
  // Groups that will never be a sample (a nearer one won their tick) go to `discarded`.
  std::vector<Sample> add(const Group& group, std::vector<Group>* discarded = nullptr);
  std::vector<Sample> flush();
  // No group before `no_group_before_ns` can still come: the pending tick is decided if no group
  // from then on can be nearer it (one within half a period after it).
  std::vector<Sample> settle(std::int64_t no_group_before_ns);
  std::uint64_t missed_ticks() const { return missed_; }
  std::int64_t tick_time(std::int64_t tick) const;

 private:
  std::int64_t anchor_ns_;
  double period_ns_;
  std::optional<Sample> best_;
  std::int64_t last_emitted_ = -1;
  std::uint64_t missed_ = 0;
};

// Pairs each sample time with the pressure frame nearest in mapped time, and the frames
// just before and after it, so readers can interpolate. Pressure frames may arrive late
// and out of order by up to `window_ns`; a sample is decided once pressure has been seen
// `window_ns` past it (or at flush). Samples may lag the newest pressure by up to
// `sample_lag_ns` (the grouper's wait and the grid's period); older frames are forgotten,
// so memory is bounded by that span. What cannot be paired is counted by reason.
struct Pairing {
  std::int64_t sample_ns = 0;
  std::optional<FrameRef> nearest, before, after;  // before <= sample_ns < after
  std::int64_t offset_ns = 0;                      // nearest.t - sample_ns
};
// The frames of `sorted` (by time) around `t`, and the nearest of them if within `max_offset_ns`;
// all of one connection (a frame of another is left out).
template <class It>
Pairing pair_nearest(It begin, It end, std::int64_t t, std::int64_t max_offset_ns);

class PressureAligner {
 public:
  using Pairing = sync::Pairing;
  PressureAligner(std::int64_t window_ns, std::int64_t max_offset_ns, std::int64_t sample_lag_ns = 1'500'000'000);
  void add_pressure(const FrameRef& frame);
  void add_sample(std::int64_t sample_ns, std::uint64_t key);
  // Decided pairings with the key given to add_sample; unpaired ones have no `nearest`.
  // Samples before `give_up_before_ns` are decided even if no pressure came after them
  // (the Sensel went silent; the cameras' clock says time has moved on).
  std::vector<std::pair<std::uint64_t, Pairing>> take(bool flush = false, std::int64_t give_up_before_ns = INT64_MIN);

  const std::map<std::string, std::uint64_t>& unpaired() const { return unpaired_; }
  std::size_t buffered() const { return frames_.size(); }

 private:
  Pairing pair(std::int64_t t) const;
  std::deque<FrameRef> frames_;  // sorted by time
  std::deque<std::pair<std::int64_t, std::uint64_t>> samples_;
  std::int64_t newest_ = INT64_MIN;
  std::int64_t decided_until_ = INT64_MIN;  // the latest sample time already paired
  std::int64_t window_ns_, max_offset_ns_, sample_lag_ns_;
  std::map<std::string, std::uint64_t> unpaired_;
};

template <class It>
Pairing pair_nearest(It begin, It end, std::int64_t t, std::int64_t max_offset_ns) {
  Pairing p;
  p.sample_ns = t;
  It after = begin, lo = begin, hi = end;
  while (lo < hi) {  // first frame later than t
    It mid = lo + (hi - lo) / 2;
    if (mid->t_ns <= t)
      lo = mid + 1;
    else
      hi = mid;
  }
  after = lo;
  if (after != end) p.after = *after;
  if (after != begin) p.before = *(after - 1);
  const FrameRef* best = p.before ? &*p.before : nullptr;
  if (p.after && (!best || p.after->t_ns - t < t - best->t_ns)) best = &*p.after;
  if (best && (best->t_ns > t ? best->t_ns - t : t - best->t_ns) <= max_offset_ns) {
    p.nearest = *best;
    p.offset_ns = best->t_ns - t;
  }
  // The three are of one connection (the store keeps one for them): the nearest frame's, else the
  // one before's. A reconnect's gap is never interpolated across.
  const std::uint32_t connection = p.nearest ? p.nearest->connection : p.before ? p.before->connection : 0;
  if (p.before && p.before->connection != connection) p.before.reset();
  if (p.after && p.after->connection != connection) p.after.reset();
  return p;
}

}  // namespace pvcap::sync
