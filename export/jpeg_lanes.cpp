#include "export/jpeg_lanes.h"

#include <algorithm>
#include <string_view>

#include <fmt/format.h>

#include "calib/projection.h"
#include "codec/image_files.h"
#include "core/durable_folder.h"
#include "export/sha256.h"

namespace pvcap::exporting {

namespace fs = std::filesystem;

Result<std::unique_ptr<JpegLanes>> JpegLanes::open(const fs::path& session, Settings settings) {
  const std::size_t lanes = std::clamp<std::size_t>(std::thread::hardware_concurrency(), 1,
                                                    std::max<std::size_t>(settings.cameras.size(), 1));
  std::vector<std::unique_ptr<SessionReader>> readers;
  while (readers.size() < lanes) {
    auto opened = SessionReader::open(session);
    if (!opened) return opened.error();
    readers.push_back(std::move(opened.value()));
  }
  return std::unique_ptr<JpegLanes>(new JpegLanes(std::move(settings), std::move(readers)));
}

JpegLanes::JpegLanes(Settings settings, std::vector<std::unique_ptr<SessionReader>> readers)
    : settings_(std::move(settings)), readers_(std::move(readers)) {}

JpegLanes::~JpegLanes() {
  FileSums ignored;
  (void)finish(/*abandon=*/true, ignored);
}

void JpegLanes::start(const std::vector<std::size_t>& samples, const fs::path& dir, const std::atomic<bool>& stop) {
  lanes_ = std::vector<Lane>(readers_.size());
  for (std::size_t k = 0; k < settings_.cameras.size(); ++k) lanes_[k % lanes_.size()].cameras.push_back(k);
  for (auto& lane : lanes_) lane.wrote.assign(samples.size(), 0);
  failed_ = false;
  abandoned_ = false;
  for (std::size_t l = 0; l < lanes_.size(); ++l)
    threads_.emplace_back([this, l, &samples, dir, &stop] {
      try {
        run(l, samples, dir, stop);
      } catch (const std::exception& e) {  // OpenCV's, or memory: the export stops with it
        std::lock_guard lock(mu_);
        lanes_[l].status = Error{fmt::format("{}: {}", dir.string(), e.what())};
        lanes_[l].finished = samples.size();
        failed_ = true;
        cv_.notify_all();
      }
    });
}

Status JpegLanes::write_one(SessionReader& reader, std::size_t sample, std::size_t k, const fs::path& dir,
                            const fs::path& jpg, Lane& lane) {
  // A crop reads its region alone (a tiled raw video decodes the tiles under it): the same pixels
  // as the whole image cut there (storage/index/session_reader.h).
  auto image = settings_.crop ? reader.image_region(sample, settings_.cameras[k], settings_.crops[k])
                              : reader.image(sample, settings_.cameras[k]);
  if (!image) return image.error();
  if (image.value().empty()) return Error{fmt::format("{}: sample {} has no frame of camera {}", jpg.string(), sample, k)};
  const cv::Mat frame = settings_.crop ? calib::apply_crop(image.value(), cv::Rect({0, 0}, image.value().size()))
                                       : image.value();
  const auto size = encode_jpeg_into(frame, settings_.quality, lane.jpeg);
  if (!size) return Error{fmt::format("{}: {}", jpg.string(), size.error().message)};
  const std::string_view encoded(reinterpret_cast<const char*>(lane.jpeg.data()), size.value());
  if (Status w = write_file_atomically(jpg, encoded, Durability::Renamed); !w.ok()) return w;
  lane.sums.push_back({jpg.lexically_relative(dir).string(), {encoded.size(), sha256_hex(encoded)}});
  return {};
}

void JpegLanes::run(std::size_t l, const std::vector<std::size_t>& samples, const fs::path& dir,
                    const std::atomic<bool>& stop) {
  Lane& lane = lanes_[l];
  Status status;
  for (std::size_t t = 0; t < samples.size() && status.ok() && !stop.load() && !failed_ && !abandoned_; ++t) {
    bool wrote = false;
    for (std::size_t k : lane.cameras) {
      const fs::path jpg = dir / fmt::format("camera_{}", k) / fmt::format("{:05d}.jpg", t);
      if (fs::exists(jpg)) continue;
      status = write_one(*readers_[l], samples[t], k, dir, jpg, lane);
      if (!status.ok()) break;
      wrote = true;
    }
    std::lock_guard lock(mu_);
    lane.wrote[t] = wrote;
    lane.finished = t + 1;
    cv_.notify_all();
  }
  std::lock_guard lock(mu_);
  lane.status = status;
  if (!status.ok()) failed_ = true;
  lane.finished = samples.size();  // done, stopped or failed: the follower waits no more
  cv_.notify_all();
}

bool JpegLanes::wait_past(std::size_t t) {
  std::unique_lock lock(mu_);
  cv_.wait(lock,
           [&] { return std::all_of(lanes_.begin(), lanes_.end(), [&](const Lane& l) { return l.finished > t; }); });
  return !failed_;
}

bool JpegLanes::wrote(std::size_t t) const {
  return std::any_of(lanes_.begin(), lanes_.end(), [&](const Lane& l) { return t < l.wrote.size() && l.wrote[t]; });
}

Status JpegLanes::finish(bool abandon, FileSums& sums) {
  if (abandon) abandoned_ = true;
  for (auto& t : threads_) t.join();
  threads_.clear();
  Status status;
  for (auto& lane : lanes_) {
    if (status.ok() && !lane.status.ok()) status = lane.status;
    for (auto& [name, sum] : lane.sums) sums[name] = std::move(sum);
  }
  lanes_.clear();
  return status;
}

}  // namespace pvcap::exporting
