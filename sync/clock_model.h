#pragma once
// Maps one stream's device clock onto pvcap's CLOCK_MONOTONIC.
//
// Every frame gives a pair (device time, host arrival time). Arrival is the true
// instant plus a latency that is never negative and often large (a USB poll, a
// busy core), so the pairs lie on or above the line `arrival = device + offset +
// skew * device`: the model fits that lower envelope, never the cloud (least
// squares would fold the mean latency and its outliers into the offset).
//
// The envelope is kept as the earliest arrival in each bin of device time (0.5 s;
// bins double when a recording grows long, so memory is bounded). The slope is the
// median of slopes between bin minima half the segment apart: long baselines, and
// a few bins whose minimum came late (a busy start-up) barely move it. The line is
// then lowered onto the lowest bin minimum. (The convex-hull / LP estimate - the
// hull edge at the mean device time - was tried first: when few arrivals reach the
// minimum latency its edge can rest on two nearby vertices, and a simulated camera's
// slope came out 45 ppm wrong; see docs/performance-log.md.) While the pairs span only a
// moment the slope means nothing, so the model assumes no drift until they span
// `min_span_for_skew_ns`, and never believes more than `max_skew`.
//
// A device clock that restarts (power cycle, replug) or jumps shows as device time
// going back by more than `reset_back_ns` (or back at all, many times in a row), or
// as arrivals far below what the line allows, or as a run of arrivals far above it;
// each starts a new segment with a fresh fit. A single pair a little back in device
// time (reordered) is ignored.
//
// What no fit of arrival times can see is the constant part of the latency (exposure,
// readout, transfer, USB polling): the line is the *earliest possible arrival*.
// `latency_ns` (from the rig file or a device's datasheet) is subtracted to reach the
// instant the device stamped. Nor can it tell a slowly wandering latency floor (a busy
// machine) from drift. A device that can be asked for its clock (GigE Vision's timestamp
// latch) gives probes instead: the device time read at an instant known to lie between
// two host times. Once a segment has probes spanning `min_span_for_skew_ns`, they define
// the mapping (the line through the widest band all the probes' brackets leave open, at its
// centre) and no latency is subtracted: the probe reads the clock the frames are stamped with.
// Before that, from its first probe on, the segment is mapped by its probes with no drift (the
// centre of what their brackets leave open at slope 0; if they disagree, the tightest one's
// centre): a bracket bounds its error, while the first arrivals at a loaded start may all be late
// by tens of milliseconds, which no envelope of them can see. Probes taken before the first frame
// are kept for the first segment.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "sync/clock_fit.h"

namespace pvcap::sync {

struct ClockModelOptions {
  std::int64_t latency_ns = 0;                        // constant latency known from the rig file / datasheet
  // From the instant a stamp marks to the instant its data shows (a camera stamping the start of its
  // exposure: half the exposure). Applied to every mapping, probed or not.
  std::int64_t stamp_to_instant_ns = 0;
  std::int64_t reset_below_ns = 20'000'000;           // an arrival this far *before* the line: the clock jumped
  std::int64_t reset_above_ns = 1'000'000'000;        // this far after it, `reset_run` times in a row: it jumped too
  std::int64_t reset_back_ns = 1'000'000'000;         // device time this far back: restarted (less: a reordered pair)
  int reset_run = 16;                                 // ...or back at all, this many times in a row
  double max_skew = 1e-3;                             // crystal clocks: a slope beyond +-1000 ppm is noise, not drift
  std::int64_t min_span_for_skew_ns = 2'000'000'000;  // until the pairs span this, assume no drift
  std::int64_t bin_ns = 500'000'000;                  // the envelope's resolution in device time...
  std::size_t max_bins = 4096;                        // ...doubled whenever it would need more bins than this
  std::size_t max_probes = 512;                       // probes kept per segment (thinned to the tighter of each pair)
};

class ClockModel {
 public:
  explicit ClockModel(ClockModelOptions options = {}) : options_(options) {}

  // Adds a pair; returns true when it began a new segment (the clock was reset).
  bool add(std::int64_t device_ns, std::int64_t arrival_ns);
  // Adds a probe: the device clock read `device_ns` at a host instant in [host_lo_ns, host_hi_ns].
  void add_probe(std::int64_t device_ns, std::int64_t host_lo_ns, std::int64_t host_hi_ns);

  // The host instant of the data the device stamped `device_ns` (a camera's: the middle of its exposure).
  std::int64_t map(std::int64_t device_ns) const {
    return (probed_ ? probe_fit_.map(device_ns) : fit_.map(device_ns) - options_.latency_ns) +
           options_.stamp_to_instant_ns;
  }
  bool probed() const { return probed_; }  // the current segment is mapped by probes
  // How far an arrival lies above the line (>= 0 up to rounding): the latency beyond the minimum.
  std::int64_t residual(std::int64_t device_ns, std::int64_t arrival_ns) const {
    return arrival_ns - fit_.map(device_ns);
  }

  const ClockFit& fit() const { return fit_; }
  // Every segment so far with its latest fit (the current one last), for re-mapping a
  // recording once it is complete: a segment covers arrivals from `first_arrival_ns` on.
  struct Segment {
    std::int64_t first_arrival_ns = 0;
    ClockFit fit;                 // host = fit.map(device) - latency_ns
    // The declared latency (none when the fit comes from probes), less the stamp-to-instant time:
    // what is subtracted from the fit, as the store's clock_models.latency_ns.
    std::int64_t latency_ns = 0;
  };
  const std::vector<Segment>& segments() const { return segments_; }
  std::int64_t latency_ns() const { return options_.latency_ns; }
  int segment() const { return segment_; }
  std::size_t pairs() const { return n_; }                      // in this segment
  std::size_t envelope_points() const { return bins_.size(); }  // bin minima kept

 private:
  struct Point {
    std::int64_t x;  // device - x0
    std::int64_t y;  // arrival - device
  };
  void start_segment(std::int64_t device_ns, std::int64_t arrival_ns);
  void refit();
  void refit_probes();
  // Width of the band every probe's bracket leaves open for this slope (negative: they
  // disagree); `centre` gets the offset in its middle.
  double probe_band(double slope, double* centre = nullptr) const;
  void publish();  // the current segment's mapping into segments_

  ClockModelOptions options_;
  std::vector<Point> bins_;  // the earliest arrival per bin of device time, x increasing
  std::int64_t bin_ns_ = 0;
  std::vector<double> slopes_;  // scratch for refit()
  struct Probe {
    std::int64_t x;       // device - x0
    std::int64_t lo, hi;  // host bracket - device
  };
  std::vector<Probe> probes_;  // this segment's
  struct EarlyProbe {
    std::int64_t device_ns, host_lo_ns, host_hi_ns;
  };
  std::vector<EarlyProbe> before_first_frame_;  // probes that came before any segment began
  ClockFit probe_fit_;
  bool probed_ = false;
  ClockFit fit_;
  std::vector<Segment> segments_;
  std::size_t n_ = 0;
  std::int64_t last_x_ = 0;
  int above_run_ = 0;
  int behind_run_ = 0;
  int segment_ = -1;
};

}  // namespace pvcap::sync
