#pragma once
// What `import pvcap` reads from a session, in plain C++ (python/module.cpp only converts it): the
// samples as columns, the takes, and each sample's image and pressure, cropped and sized as a
// network wants them, through the same reader, calibration and crop the export and replay use
// (storage/index/session_reader.h, calib/recorded_calibration.h, calib/projection.h). One implementation
// of the store: Python never parses session.db or a video itself. Read-only.
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include <opencv2/core.hpp>

#include "calib/projection.h"
#include "calib/rig_calibration.h"
#include "core/result.h"
#include "protocol/takes.h"
#include "storage/index/session_reader.h"

namespace pvcap::python {

// Where to cut a camera's image: all of it, the paper's crop (the pad's bounding box with a 50 px
// margin at the network's aspect, calib::paper_crop_box), or a box in the image's pixels.
struct Crop {
  enum class Kind { Whole, Paper, Box } kind = Kind::Whole;
  cv::Rect box;
};

// The 15 Hz samples as columns (one entry per sample; `present` is samples x cameras, row-major).
struct SampleColumns {
  std::vector<std::int64_t> index, tick, t_ns;
  std::vector<std::int64_t> pressure_sequence;  // -1: no pressure frame paired
  std::vector<std::uint8_t> present;            // 1: that camera's frame is in a video
  std::size_t cameras = 0;
};

class SessionAccess {
 public:
  static Result<std::unique_ptr<SessionAccess>> open(const std::filesystem::path& dir);

  SessionReader& reader() { return *reader_; }
  const std::filesystem::path& dir() const { return dir_; }
  const SampleColumns& samples() const { return samples_; }
  // This folder's takes (a resumed session's earlier folders' are theirs).
  const std::vector<protocol::TakeRow>& takes() const { return takes_; }
  // The camera's pad calibration as the session holds it (none: not calibrated).
  const std::optional<calib::CameraCalibration>& calibration(std::size_t camera) const;

  // The image of `camera` in sample `sample`, RGB (CV_8UC3), cut by `crop` and resized to `size`
  // (bilinear; none: the crop's size). Empty when the sample has no stored frame of that camera.
  Result<cv::Mat> image_rgb(std::size_t sample, std::size_t camera, const Crop& crop, std::optional<cv::Size> size);
  // The sample's pressure on the sensor's 185 x 105 grid (rows x cols = 105 x 185), in kPa, as the
  // export writes it and PressureVision's loader reads it. Empty when no pressure frame is paired.
  Result<cv::Mat> pressure_kpa(std::size_t sample);
  // The same pressure in the camera's image through the pad's homography (PressureVision's
  // sensor->image homography, the corners as measured), warped straight into the crop at its size
  // (the pixels image_rgb gives), and scaled so that its force on the pad equals the sensor's
  // (CV_32F, kPa). The map of each crop is made once per session.
  // `force_n`, when given, receives the sample's force (N; 0 when no pressure frame is paired).
  Result<cv::Mat> pressure_in_camera(std::size_t sample, std::size_t camera, const Crop& crop,
                                     std::optional<cv::Size> size, double* force_n = nullptr);
  // The force (N) the sample's pressure carries (0 when none is paired).
  Result<double> force_n(std::size_t sample);
  // The box `crop` cuts from the camera's image (the whole image for Crop::Whole); an Error for the
  // paper's crop of a camera without a pad calibration.
  Result<cv::Rect> crop_box(std::size_t camera, const Crop& crop) const;

 private:
  SessionAccess() = default;
  Status check_camera(std::size_t sample, std::size_t camera) const;

  std::filesystem::path dir_;
  std::unique_ptr<SessionReader> reader_;
  SampleColumns samples_;
  std::vector<SampleInfo> infos_;
  std::vector<protocol::TakeRow> takes_;
  std::vector<std::optional<calib::CameraCalibration>> calibrations_;
  calib::PadLayout pad_;
  std::map<std::tuple<std::size_t, int, int, int, int, int, int>, calib::ConservingWarp> warps_;
};

}  // namespace pvcap::python
