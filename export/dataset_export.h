#pragma once
// `pvcap export`: a recorded session written in the layout PressureVisionDB was released in
// (../shared/specs/pressurevision-dataset.md section 1), so its loaders and training code read it
// unchanged, or in the PressureVision++ variant (section 1.6). One call exports one session; many
// sessions are independent jobs (a cluster's job array) that may share one output folder.
//
// DIR/participants.json            which pvcap participant code became which folder (under a lock)
// DIR/<id>_<code>/<sequence>/      one folder per take, named as the dataset names them
//   camera_<c>/<t:05d>.jpg         each camera's frame of the t-th 15 Hz sample
//   force/<t:05d>.pkl (or .npy)    the pressure of that sample: 105 x 185 float32 in the loaders'
//                                  "counts" (counts / 2.7125 = kPa)
//   manifest.json                  every file's size and SHA-256
//   metadata.json (meta.json)      written last: a sequence with it is complete
//   pvcap_source.json              which session and take the folder holds (written first)
//
// Every file is written to a temporary name and renamed: an interrupted export leaves whole files
// only, and the next run skips what exists and resumes where it stopped.
#include <atomic>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/result.h"

namespace pvcap::exporting {

enum class Layout { PressureVision, PressureVisionPlus };

struct ExportOptions {
  std::filesystem::path out;
  Layout layout = Layout::PressureVision;
  std::optional<std::string> take;     // only this sequence (e.g. press_palm_high_5x_left)
  std::optional<double> from_s, to_s;  // only samples in [from, to) s from the session's start
  std::vector<std::size_t> cameras;    // indices of the session's cameras; empty: all
  int jpeg_quality = 95;
  bool npy = false;          // force frames as .npy instead of .pkl
  bool include_all = false;  // superseded, bad and interrupted takes too
  // The sequence folder each take gets, by "<step>:<start_ns>" (a dataset release names them all
  // before its jobs run, so two sessions of one participant with a take of the same name get the
  // same folders in any order of jobs); a take not named here is named as usual: its sequence
  // name, "(2)", "(3)"... after the folders other takes hold.
  std::map<std::string, std::string> sequence_folders;
  // The paper's crop (spec 2.2): each camera's frames cut to the pad with a 50 px border, grown to
  // 480:384 and resized to 480 x 384; the intrinsics and homographies follow, so the loaders' own
  // geometry lands on the cropped frames (train with CROP_IMAGES off: they are cropped already).
  bool paper_crop = false;
  // Frames written (or found) of the total to write; called often, from the exporting thread.
  std::function<void(std::size_t done, std::size_t total)> progress;
};

struct SequenceResult {
  std::string folder;  // relative to the output folder
  std::string status;  // the take's status
  std::size_t frames = 0;
  std::size_t samples_left_out = 0;  // samples missing a camera's frame or the pressure
  bool was_complete = false;         // found finished by an earlier run
};

struct CameraGeometry {
  std::string name;
  double loader_corner_rms_px = 0, loader_corner_max_px = 0;  // the loaders' corners vs the measured
};

struct ExportResult {
  std::filesystem::path participant_folder;
  std::vector<SequenceResult> sequences;
  std::vector<CameraGeometry> cameras;
  std::size_t frames_written = 0, frames_found = 0;
  bool interrupted = false;
};

Result<ExportResult> export_session(const std::filesystem::path& session, const ExportOptions& o,
                                    const std::atomic<bool>& stop);

// "LCR" -> "left center right", the words the loaders look for (spec 1.3).
std::string light_direction_words(const std::string& lighting);

}  // namespace pvcap::exporting
