#include "python/session_access.h"

#include <opencv2/imgproc.hpp>

#include <fmt/format.h>

#include "calib/projection.h"
#include "codec/sensel_units.h"
#include "calib/recorded_calibration.h"

namespace pvcap::python {

Result<std::unique_ptr<SessionAccess>> SessionAccess::open(const std::filesystem::path& dir) {
  auto reader = SessionReader::open(dir);
  if (!reader) return reader.error();
  std::unique_ptr<SessionAccess> a(new SessionAccess);
  a->dir_ = std::filesystem::absolute(dir).lexically_normal();
  a->reader_ = std::move(reader.value());
  a->pad_ = calib::default_pad_layout();
  auto calibrations = calib::pad_calibrations(*a->reader_);
  if (!calibrations) return calibrations.error();
  a->calibrations_ = std::move(calibrations.value());
  auto infos = a->reader_->sample_infos();
  if (!infos) return infos.error();
  a->infos_ = std::move(infos.value());
  const auto& cameras = a->reader_->cameras();
  SampleColumns& c = a->samples_;
  c.cameras = cameras.size();
  c.present.assign(a->infos_.size() * cameras.size(), 0);
  for (std::size_t i = 0; i < a->infos_.size(); ++i) {
    const SampleInfo& s = a->infos_[i];
    c.index.push_back(std::int64_t(s.index));
    c.tick.push_back(s.tick);
    c.t_ns.push_back(s.t_ns);
    c.pressure_sequence.push_back(s.pressure ? std::int64_t(s.pressure->sequence) : -1);
    for (const SampleCamera& sc : s.cameras)
      for (std::size_t k = 0; k < cameras.size(); ++k)
        if (cameras[k].device_id == sc.device_id && sc.in_video) c.present[i * cameras.size() + k] = 1;
  }
  // A session without a protocol has no takes: that is not an error for a reader.
  if (auto takes = protocol::read_takes(dir)) {
    for (auto& t : takes.value().takes)
      if (std::filesystem::absolute(t.session).lexically_normal() == a->dir_) a->takes_.push_back(std::move(t));
  }
  return a;
}

const std::optional<calib::CameraCalibration>& SessionAccess::calibration(std::size_t camera) const {
  static const std::optional<calib::CameraCalibration> none;
  return camera < calibrations_.size() ? calibrations_[camera] : none;
}

Status SessionAccess::check_camera(std::size_t sample, std::size_t camera) const {
  if (sample >= infos_.size())
    return Error{fmt::format("{}: no sample {} (the session has {})", dir_.string(), sample, infos_.size())};
  if (camera >= reader_->cameras().size())
    return Error{
        fmt::format("{}: no camera {} (the session has {})", dir_.string(), camera, reader_->cameras().size())};
  return {};
}

Result<cv::Rect> SessionAccess::crop_box(std::size_t camera, const Crop& crop) const {
  if (camera >= reader_->cameras().size())
    return Error{
        fmt::format("{}: no camera {} (the session has {})", dir_.string(), camera, reader_->cameras().size())};
  const CameraInfo& cam = reader_->cameras()[camera];
  const cv::Rect whole(0, 0, cam.width, cam.height);
  switch (crop.kind) {
    case Crop::Kind::Whole:
      return whole;
    case Crop::Kind::Box:
      if (crop.box.width <= 0 || crop.box.height <= 0 || (crop.box & whole) != crop.box)
        return Error{fmt::format("crop ({}, {}, {}, {}) is not inside camera {}'s {}x{} image", crop.box.x, crop.box.y,
                                 crop.box.width, crop.box.height, cam.name, cam.width, cam.height)};
      return crop.box;
    case Crop::Kind::Paper: {
      const auto& cal = calibration(camera);
      if (!cal || !cal->pad_corners_px)
        return Error{
            fmt::format("{}: camera {} has no pad calibration, so it has no paper crop: run `pvcap "
                        "calibrate pad {}`",
                        dir_.string(), cam.name, dir_.string())};
      return calib::paper_crop_box(*cal->pad_corners_px, {cam.width, cam.height});
    }
  }
  return whole;
}

namespace {
cv::Mat cut_and_size(const cv::Mat& image, const cv::Rect& box, std::optional<cv::Size> size, int interpolation) {
  cv::Mat cut = image(box);
  if (!size || *size == box.size()) return cut.clone();
  cv::Mat out;
  cv::resize(cut, out, *size, 0, 0, interpolation);
  return out;
}
}  // namespace

Result<cv::Mat> SessionAccess::image_rgb(std::size_t sample, std::size_t camera, const Crop& crop,
                                         std::optional<cv::Size> size) {
  if (Status s = check_camera(sample, camera); !s.ok()) return s.error();
  auto box = crop_box(camera, crop);
  if (!box) return box.error();
  auto bgr = reader_->image_region(sample, camera, box.value());  // a raw frame: only the box demosaiced
  if (!bgr) return bgr.error();
  if (bgr.value().empty()) return cv::Mat();
  // Sized first, then its channels swapped: the same pixels (each channel is resized alone), and
  // the swap works on the network's size, not on the crop's (~900x720 at 1080p).
  cv::Mat sized = cut_and_size(bgr.value(), cv::Rect({0, 0}, bgr.value().size()), size, cv::INTER_LINEAR), rgb;
  cv::cvtColor(sized, rgb, cv::COLOR_BGR2RGB);
  return rgb;
}

Result<cv::Mat> SessionAccess::pressure_kpa(std::size_t sample) {
  if (sample >= infos_.size())
    return Error{fmt::format("{}: no sample {} (the session has {})", dir_.string(), sample, infos_.size())};
  const auto& ref = infos_[sample].pressure;
  if (!ref) return cv::Mat();
  auto p = reader_->pressure_frame(ref->sequence, ref->connection);
  if (!p) return p.error();
  const PressureFrame& f = p.value();
  const sensel::Grid grid{f.grid_cols, f.grid_rows, f.grid_xscale, f.grid_yscale};
  const std::vector<float> up = sensel::upsample(f.counts, grid);
  cv::Mat out(grid.out_rows(), grid.out_cols(), CV_32F);
  for (std::size_t i = 0; i < up.size(); ++i) out.at<float>(int(i)) = float(sensel::upsampled_sensel_kpa(up[i], grid));
  return out;
}

Result<double> SessionAccess::force_n(std::size_t sample) {
  auto kpa = pressure_kpa(sample);
  if (!kpa) return kpa.error();
  return kpa.value().empty() ? 0.0 : calib::sensor_force_n(kpa.value(), pad_);
}

Result<cv::Mat> SessionAccess::pressure_in_camera(std::size_t sample, std::size_t camera, const Crop& crop,
                                                  std::optional<cv::Size> size, double* force_n) {
  if (force_n) *force_n = 0;
  if (Status s = check_camera(sample, camera); !s.ok()) return s.error();
  auto box = crop_box(camera, crop);
  if (!box) return box.error();
  const auto& cal = calibration(camera);
  const CameraInfo& cam = reader_->cameras()[camera];
  if (!cal || !cal->pad_corners_px)
    return Error{
        fmt::format("{}: camera {} has no pad calibration, so its pressure cannot be put in its image: run "
                    "`pvcap calibrate pad {}`",
                    dir_.string(), cam.name, dir_.string())};
  auto kpa = pressure_kpa(sample);
  if (!kpa) return kpa.error();
  if (kpa.value().empty()) return cv::Mat();
  const cv::Rect b = box.value();
  const cv::Size out = size.value_or(b.size());
  const auto key = std::make_tuple(camera, b.x, b.y, b.width, b.height, out.width, out.height);
  auto warp = warps_.find(key);
  if (warp == warps_.end()) {
    // PressureVision's homography maps the grid's outer edges (0..185, 0..105) to the corners; the
    // pressure image's cell centres sit at integers, half a cell inside them. The crop and its
    // resize are an affine map of image pixels (cv::resize takes pixel centre x of the box to
    // (x - x0 + 0.5) * s - 0.5), so the pressure is warped straight into the crop at its size, as
    // PressureVision's loader warps into its crop.
    const auto& c = *cal->pad_corners_px;
    const std::vector<cv::Point2f> edges{
        {0, 0}, {float(pad_.cols), 0}, {float(pad_.cols), float(pad_.rows)}, {0, float(pad_.rows)}};
    const std::vector<cv::Point2f> image{cv::Point2f(c[0]), cv::Point2f(c[1]), cv::Point2f(c[2]), cv::Point2f(c[3])};
    const cv::Matx33d edges_to_image = cv::getPerspectiveTransform(edges, image);
    const cv::Matx33d centres_to_edges(1, 0, 0.5, 0, 1, 0.5, 0, 0, 1);
    const double sx = double(out.width) / b.width, sy = double(out.height) / b.height;
    const cv::Matx33d image_to_crop(sx, 0, (0.5 - b.x) * sx - 0.5, 0, sy, (0.5 - b.y) * sy - 0.5, 0, 0, 1);
    warp =
        warps_.emplace(key, calib::ConservingWarp(image_to_crop * edges_to_image * centres_to_edges, out, pad_)).first;
  }
  return warp->second(kpa.value(), force_n);
}

}  // namespace pvcap::python
