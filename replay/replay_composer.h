#pragma once
// One picture of a recorded session at one sample: the camera views in a 2 x 2 grid with the
// pressure drawn over each through that camera's calibration (inferno, black = no pressure,
// transparent where there is none), and a panel with the pressure image itself and what was
// happening: the take's action, hand, force level, repetitions, status, and the time. What the
// replay window shows and what `pvcap replay --out` renders, the same picture.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "calib/projection.h"
#include "core/result.h"
#include "storage/index/session_reader.h"
#include "storage/video/view_video.h"

namespace pvcap::replay {

// Where things are in the picture (fixed, so a test can find a camera's view).
struct Layout {
  static constexpr int kViewWidth = 640, kViewHeight = 360;  // each camera, 16:9
  static constexpr int kPanelWidth = 400;
  static constexpr int kWidth = 2 * kViewWidth + kPanelWidth, kHeight = 2 * kViewHeight;
  // Camera c's tile: row c / 2, column c % 2.
  static cv::Rect view(std::size_t camera) {
    return {int(camera % 2) * kViewWidth, int(camera / 2) * kViewHeight, kViewWidth, kViewHeight};
  }
  // Where an image of `image` size is shown in its tile: as large as fits, its aspect kept, centred
  // (in tile coordinates).
  static cv::Rect fitted(cv::Size image) {
    const double s = std::min(double(kViewWidth) / image.width, double(kViewHeight) / image.height);
    const int w = int(std::lround(image.width * s)), h = int(std::lround(image.height * s));
    return {(kViewWidth - w) / 2, (kViewHeight - h) / 2, w, h};
  }
};

// The view videos are recorded for this tile: a 1080p camera's fills it without scaling.
static_assert(Layout::kViewWidth == pvcap::kViewWidth && Layout::kViewHeight == pvcap::kViewHeight,
              "storage/video/view_video.h makes view videos of the replay's tile size");

// The take a sample belongs to, as the operator page names it.
struct TakeLabel {
  std::string name, action, hand, force, status;
  int repetitions = 0;
};

class ReplayComposer {
 public:
  // Reads the session's calibrations and takes (of folder `dir`, the reader's) once. Sets the
  // reader to half-size demosaicing (the views are smaller than that).
  // `pressure_full_scale_kpa`: the top of the colour map (the same for the whole session, so
  // presses compare).
  static Result<ReplayComposer> open(SessionReader& reader, const std::filesystem::path& dir,
                                     double pressure_full_scale_kpa = 60);

  // The picture of sample i (Layout::kWidth x kHeight, BGR).
  Result<cv::Mat> compose(std::size_t i);
  // The same with the cameras' images already read (cameras() order, half size; empty: not stored),
  // as a renderer that decodes ahead on its own readers has them.
  Result<cv::Mat> compose(std::size_t i, std::vector<cv::Mat> images);
  // The take sample i belongs to, if any.
  std::optional<TakeLabel> take_at(std::size_t i) const;
  // The samples of the take named `name` ([first, end)); an Error listing the takes otherwise.
  Result<std::pair<std::size_t, std::size_t>> take_samples(const std::string& name) const;
  // The first sample of every take (retakes too), in order: what the window's next/previous take
  // keys jump between.
  std::vector<std::size_t> take_starts() const;
  // Whether compose(i) reads the cameras' view videos where the session has them (the default), or
  // always their own videos (storage/video/view_video.h).
  void set_view_videos(bool on) { view_videos_ = on; }
  // Whether camera c has a calibration to draw the pressure through.
  bool calibrated(std::size_t camera) const { return camera < projectors_.size() && projectors_[camera].has_value(); }

 private:
  explicit ReplayComposer(SessionReader& reader) : reader_(&reader) {}
  SessionReader* reader_;
  std::filesystem::path dir_;
  // One more reader per camera, so the cameras' frames decode in parallel (a reader is one thread's).
  std::vector<std::unique_ptr<SessionReader>> camera_readers_;
  double full_scale_kpa_ = 60;
  bool view_videos_ = true;
  std::vector<std::optional<calib::PressureProjector>> projectors_;  // per camera, at the view's size
  struct Take {
    TakeLabel label;
    std::size_t first = 0, end = 0;
  };
  std::vector<Take> takes_;
};

}  // namespace pvcap::replay
