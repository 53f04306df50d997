// The session reader's pictures: each sample's camera frames decoded from the videos (raw mosaics
// demosaiced, a region alone where it can be), with the videos held open across reads.
#include <algorithm>

#include <fmt/format.h>

#include "storage/index/session_reader.h"
#include "storage/index/session_reader_internal.h"
#include "storage/video/video_reader.h"

namespace pvcap {

using session_reader_detail::guarded;
using session_reader_detail::opt_int;

namespace {
constexpr std::size_t kMaxOpenVideos = 16;
// A camera's segments are read in order: its current one and the one before stay open (a step
// back across the boundary), not every segment read so far (each holds ~10 MB of decoder and
// picture buffers, and an hour-long session has dozens per camera).
constexpr std::size_t kMaxOpenVideosPerCamera = 2;
}  // namespace

Result<cv::Mat> SessionReader::camera_image(const SampleCamera& c, bool mosaic, std::string* bayer_format,
                                            std::optional<cv::Rect> region) {
  return guarded(dir_, [&]() -> Result<cv::Mat> {
    // Stores before version 5 have no checksums.
    auto q = db_->cached(fmt::format(
        "SELECT f.video_file_id, f.host_ns, v.path, f.video_pts_ms, {} FROM frames f JOIN video_files v ON v.id = "
        "f.video_file_id "
        "WHERE f.device_id = ? AND f.connection = ? AND f.sequence = ? AND f.kept = 1",
        info_.schema_version >= 5 ? "f.checksum" : "NULL"));
    q.bind_all(c.device_id, std::int64_t(c.connection), c.sequence);
    if (!q.step())
      return Error{fmt::format("{}: frame {} of device {} is not in a video", dir_.string(), c.sequence, c.device_id)};
    const std::int64_t file_id = q.column_int(0);
    const VideoTimestamp ts = video_timestamp(opt_int(q, 3), q.column_int(1), info_.started_host_ns);
    const std::string rel = q.column_text(2);
    const std::optional<std::int64_t> checksum = opt_int(q, 4);
    if (rel.empty() || rel.find("..") != std::string::npos || rel.front() == '/')
      return Error{fmt::format("{}: video path '{}' leaves the session folder", dir_.string(), rel)};
    // A viewer's read (half-size colour, nothing checked) skips a raw video's second green where
    // the video allows it (storage/video/video_reader.h); a read that wants the mosaic or its checksum
    // needs it whole. Which, depends on the read and the file alone, never on the reads before: the
    // same read gives the same image.
    if (view_videos_ && !mosaic && !(check_checksums_ && checksum))
      if (auto view = views_.image(file_id, rel, ts.ms, ts.tolerance_ms, image_size_)) return std::move(*view);
    const bool views_only = !mosaic && demosaic_ == Demosaic::HalfSize && !(check_checksums_ && checksum);
    auto it = videos_.find(file_id);
    if (it != videos_.end()) {
      const VideoReader& open = *it->second.reader;
      if (open.decodes_three_planes() != (views_only && open.can_decode_three_planes())) {
        videos_.erase(it);
        it = videos_.end();
      }
    }
    if (it == videos_.end()) {
      // The earliest of this camera's open segments goes first, then the earliest of all.
      std::size_t of_camera = 0;
      auto earliest_of_camera = videos_.end();
      for (auto v = videos_.begin(); v != videos_.end(); ++v)
        if (v->second.device_id == c.device_id && of_camera++ == 0) earliest_of_camera = v;
      if (of_camera >= kMaxOpenVideosPerCamera)
        videos_.erase(earliest_of_camera);
      else if (videos_.size() >= kMaxOpenVideos)
        videos_.erase(videos_.begin());
      VideoReader::Options options;
      options.half_size_colour_only = views_only;
      auto opened = VideoReader::open(dir_ / rel, options);
      if (!opened) return opened.error();
      it = videos_.emplace(file_id, OpenVideo{c.device_id, std::move(opened.value())}).first;
    }
    VideoReader& video = *it->second.reader;
    if (bayer_format) *bayer_format = video.bayer_format();
    video.set_demosaic(demosaic_);
    video.set_image_size(image_size_);
    cv::Mat bgr;
    if (region && !video.raw()) return cv::Mat();  // a colour video has no mosaic: the caller cuts its image
    auto found = region   ? video.read_raw_region_at(ts.ms, *region, bgr, ts.tolerance_ms)
                 : mosaic ? video.read_raw_at(ts.ms, bgr, ts.tolerance_ms)
                          : video.read_at(ts.ms, bgr, ts.tolerance_ms);
    if (!found) return found.error();
    if (!found.value())
      return Error{fmt::format("{}: no frame at {} ms in {}", dir_.string(), ts.ms, (dir_ / rel).string())};
    if (check_checksums_ && checksum && !region) {
      const auto crc = video.decoded_picture_crc();
      if (crc && *crc != std::uint32_t(*checksum))
        return Error{fmt::format(
            "{}: frame {} (connection {}) of device {} at {} ms: its pixels are not the bytes the "
            "camera sent (checksum at capture {:08x}, stored picture {:08x})",
            (dir_ / rel).string(), c.sequence, c.connection, c.device_id, ts.ms, std::uint32_t(*checksum), *crc)};
    }
    return bgr;
  });
}

void SessionReader::set_demosaic(Demosaic method) { demosaic_ = method; }

Result<cv::Mat> SessionReader::image(std::size_t i, std::size_t camera) { return one_image(i, camera, false); }
Result<cv::Mat> SessionReader::raw_image(std::size_t i, std::size_t camera) { return one_image(i, camera, true); }

Result<cv::Mat> SessionReader::image_region(std::size_t i, std::size_t camera, cv::Rect box) {
  if (camera < cameras_.size() && (box & cv::Rect(0, 0, cameras_[camera].width, cameras_[camera].height)) != box)
    return Error{fmt::format("{}: ({}, {}, {}, {}) is not inside camera {}'s {}x{} image", dir_.string(), box.x, box.y,
                             box.width, box.height, cameras_[camera].name, cameras_[camera].width,
                             cameras_[camera].height)};
  if (demosaic_ == Demosaic::Bilinear && image_size_ == cv::Size() && !view_videos_ && camera < cameras_.size()) {
    // Bilinear demosaicing reads each pixel's 3x3 neighbours: a margin of 2 from an even corner
    // (the pattern's phase kept) gives the box the whole image's pixels. Only that part of the
    // mosaic is read (a tiled video decodes the tiles under it), unless checksums are checked:
    // they hold for a whole frame.
    const cv::Size size(cameras_[camera].width, cameras_[camera].height);
    const int x0 = std::max(0, box.x - 2) & ~1, y0 = std::max(0, box.y - 2) & ~1;
    const int x1 = std::min(size.width, (box.br().x + 3) & ~1), y1 = std::min(size.height, (box.br().y + 3) & ~1);
    const cv::Rect margin(x0, y0, x1 - x0, y1 - y0);
    std::string format;
    auto mosaic = check_checksums_ || size.width % 2 || size.height % 2
                      ? one_image(i, camera, true, &format)  // an Error for a colour video: cut below
                      : one_image(i, camera, true, &format, margin);
    if (mosaic && !format.empty() && !mosaic.value().empty()) {
      const cv::Mat m = mosaic.value().size() == margin.size() ? mosaic.value() : mosaic.value()(margin);
      cv::Mat bgr;
      if (Status d = debayer(m, format, demosaic_, bgr); !d.ok()) return d.error();
      return bgr(cv::Rect(box.x - x0, box.y - y0, box.width, box.height)).clone();
    }
    // No stored frame of the camera in this sample, or a colour video: the whole image, cut below.
  }
  auto whole = image(i, camera);
  if (!whole || whole.value().empty()) return whole;
  if ((box & cv::Rect({0, 0}, whole.value().size())) != box)
    return Error{fmt::format("{}: ({}, {}, {}, {}) is not inside the {}x{} image", dir_.string(), box.x, box.y,
                             box.width, box.height, whole.value().cols, whole.value().rows)};
  return whole.value()(box).clone();
}

Result<cv::Mat> SessionReader::one_image(std::size_t i, std::size_t camera, bool mosaic, std::string* bayer_format,
                                         std::optional<cv::Rect> region) {
  if (camera >= cameras_.size())
    return Error{fmt::format("{}: no camera {} (the session has {})", dir_.string(), camera, cameras_.size())};
  auto info = sample_info(i);
  if (!info) return info.error();
  for (const auto& c : info.value().cameras)
    if (c.device_id == cameras_[camera].device_id)
      return c.in_video ? camera_image(c, mosaic, bayer_format, region) : Result<cv::Mat>(cv::Mat());
  return cv::Mat();
}

}  // namespace pvcap
