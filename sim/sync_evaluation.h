#pragma once
// How well a simulated session put every stream on one clock and paired its pressure frames,
// measured against the simulator's ground truth (sim-truth/), with naive arrival-time pairing
// measured beside it; and the hard timing scenario `pvcap eval-sync` records for it.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace pvcap::sim {

// The eval-sync rig's cam3 changes its exposure frame by frame by this much either way (its chunks
// carry each frame's: the timeline must follow them).
inline constexpr double kCam3ExposureWobbleUs = 600;

struct StreamTiming {
  std::string name;
  std::size_t frames = 0;
  double bias_ms = 0;                              // median of (mapped - true): the constant part
  double p50_ms = 0, p99_ms = 0, max_ms = 0;       // |error - bias|
  double arrival_bias_ms = 0, arrival_p99_ms = 0;  // the same for the raw arrival stamp
  bool is_camera = true;
};

struct SyncEvaluation {
  std::vector<StreamTiming> streams;
  std::size_t samples = 0, samples_complete = 0;
  std::size_t paired = 0, paired_nearest = 0;  // pvcap: samples with pressure; with the truly nearest frame
  std::size_t paired_tie = 0;                  // of the others: the chosen frame is as near, within the tie tolerance
  // Of the others: truly farther by more than the tie tolerance, but by no more than the measured
  // errors of the times compared (the sample's instant's and both frames'); the largest such excess.
  std::size_t paired_within_error = 0;
  double within_error_max_ms = 0;
  std::size_t rightly_unpaired = 0;  // no pressure, and truly no stored frame within the allowed offset
  std::size_t naive_nearest = 0;     // arrival-time pairing: with the truly nearest frame
  std::size_t naive_tie = 0;
  double warmup_s = 0;  // excluded from the timing errors
  double tie_ms = 0;
  std::vector<std::string> missed;  // targets not met, in words
  // Samples paired right: the truly nearest frame, a tie, one within the timestamps' errors, or
  // rightly none.
  std::size_t right() const { return paired_nearest + paired_tie + paired_within_error + rightly_unpaired; }
};

struct SyncTargets {
  double camera_p99_ms = 0.1, sensel_p99_ms = 0.5, bias_ms = 0.5, nearest_fraction = 0.995;
  // Two pressure frames whose true distances from a sample differ by less than this are equally
  // near at the accuracy the timestamps are asked for (half the camera target): picking either
  // is right. Streams at commensurate rates (60 Hz cameras, 125 Hz Sensel) put whole runs of
  // samples on such ties.
  double tie_ms = 0.05;
  // The pairing's own limit (TimelineConfig::pressure_max_offset_ns): a sample whose truly nearest
  // stored frame is farther than this is rightly left without pressure (the Sensel had a gap).
  double max_offset_ms = 20.0;
};

// Reads `session_dir`/session.db and `session_dir`/sim-truth. Throws UserError if either is unusable.
SyncEvaluation evaluate_sync(const std::filesystem::path& session_dir, double warmup_s,
                             const SyncTargets& targets = {});
std::string format_evaluation(const SyncEvaluation& e);

// The scenario: four VGA cameras at 60 Hz with offset, drifting clocks and a Sensel with a
// long-tailed USB delay, lost frames and a clock reset half-way. Writes `root`/eval-sync.yaml.
struct EvalScenario {
  double seconds = 30;
  double drift_ppm = 100;  // cameras get +-this (alternating), the Sensel half of it
  double jitter_ms = 4;    // Sensel USB arrival jitter cap (mean a quarter of it)
  double loss = 0.01;      // pressure frames the device loses
  std::uint64_t seed = 1;
};
std::filesystem::path write_eval_scenario(const EvalScenario& scenario, const std::filesystem::path& root);

}  // namespace pvcap::sim
