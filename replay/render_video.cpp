#include "replay/render_video.h"

#include <chrono>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <thread>

#include <fmt/format.h>

#include "replay/replay_composer.h"
#include "storage/index/session_reader.h"
#include "storage/video/video_writer.h"

namespace pvcap::replay {

namespace {
// One camera's images of samples [first, end), decoded ahead on a thread and a reader of its own
// (at most `depth` waiting): four of these keep both cores busy while the pictures are composed
// and encoded. Each image is made at its view's size here, straight from the decoded planes
// (docs/replay.md "Speed").
class CameraPrefetch {
 public:
  CameraPrefetch(const std::filesystem::path& dir, std::size_t camera, std::size_t first, std::size_t end,
                 std::size_t depth, bool view_videos)
      : depth_(depth), thread_([=, this] { run(dir, camera, first, end, view_videos); }) {}
  ~CameraPrefetch() {
    {
      std::lock_guard lock(mu_);
      stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  // The next sample's image (empty: that frame was not stored), waiting for it.
  Result<cv::Mat> next() {
    std::unique_lock lock(mu_);
    cv_.wait(lock, [&] { return !queue_.empty(); });
    Result<cv::Mat> r = std::move(queue_.front());
    queue_.pop_front();
    cv_.notify_all();
    return r;
  }

 private:
  void run(const std::filesystem::path& dir, std::size_t camera, std::size_t first, std::size_t end, bool view_videos) {
    auto reader = SessionReader::open(dir);
    if (reader) {
      reader.value()->set_demosaic(Demosaic::HalfSize);
      reader.value()->set_view_videos(view_videos);
      const CameraInfo& info = reader.value()->cameras()[camera];
      if (info.width > 0 && info.height > 0)
        reader.value()->set_image_size(Layout::fitted({info.width, info.height}).size());
    }
    for (std::size_t i = first; i < end; ++i) {
      Result<cv::Mat> image = reader ? reader.value()->image(i, camera) : Result<cv::Mat>(reader.error());
      std::unique_lock lock(mu_);
      cv_.wait(lock, [&] { return stop_ || queue_.size() < depth_; });
      if (stop_) return;
      queue_.push_back(std::move(image));
      cv_.notify_all();
    }
  }
  std::size_t depth_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<Result<cv::Mat>> queue_;
  bool stop_ = false;
  std::thread thread_;  // last: starts once the members above exist
};
}  // namespace

Result<RenderResult> render_replay(const std::filesystem::path& session, const RenderOptions& o,
                                   const std::function<void(std::size_t, std::size_t)>& progress,
                                   const std::atomic<bool>* stop) {
  const auto started = std::chrono::steady_clock::now();
  if (!(o.speed > 0)) return Error{fmt::format("--speed {} must be above 0", o.speed)};
  auto opened = SessionReader::open(session);
  if (!opened) return opened.error();
  SessionReader& reader = *opened.value();
  if (reader.sample_count() == 0)
    return Error{fmt::format("{}: the session has no samples to replay", session.string())};
  auto composer = ReplayComposer::open(reader, session, o.pressure_full_scale_kpa);
  if (!composer) return composer.error();

  // Which samples: a take's, or those in the time range, or all.
  std::size_t first = 0, end = reader.sample_count();
  if (o.take) {
    auto range = composer.value().take_samples(*o.take);
    if (!range) return range.error();
    std::tie(first, end) = range.value();
  }
  const std::int64_t t0 = reader.info().started_host_ns;
  auto sample_t = [&](std::size_t i) -> Result<std::int64_t> {
    auto info = reader.sample_info(i);
    if (!info) return info.error();
    return info.value().t_ns;
  };
  if (o.from_s) {
    auto at = reader.sample_at(t0 + std::int64_t(*o.from_s * 1e9));
    if (!at) return at.error();
    first = std::max(first, at.value());
  }
  if (o.to_s) {
    auto at = reader.sample_at(t0 + std::int64_t(*o.to_s * 1e9));
    if (!at) return at.error();
    end = std::min(end, at.value() + 1);
  }
  if (first >= end) return Error{fmt::format("{}: no samples in the range asked for", session.string())};
  auto t_first = sample_t(first);
  if (!t_first) return t_first.error();

  VideoSettings vs;
  vs.container = o.out.extension() == ".mkv" ? "matroska" : "mp4";
  vs.codec = "libx264";
  vs.pixel_format = "yuv420p";  // what every player takes
  vs.crf = 20;
  vs.preset = "ultrafast";
  vs.width = Layout::kWidth;
  vs.height = Layout::kHeight;
  vs.nominal_fps = 15 * o.speed;
  vs.gop_frames = 30;
  vs.threads = 1;  // the cameras decode ahead on the other threads meanwhile
  const std::filesystem::path tmp = o.out.parent_path() / (".tmp-" + o.out.filename().string());
  auto writer = VideoWriter::open(tmp, vs);
  if (!writer) return writer.error();
  auto fail = [&](Error e) -> Error {
    (void)writer.value()->close();
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    return e;
  };

  RenderResult r;
  std::vector<std::unique_ptr<CameraPrefetch>> cameras;
  for (std::size_t c = 0; c < reader.cameras().size() && c < 4; ++c)
    cameras.push_back(std::make_unique<CameraPrefetch>(session, c, first, end, 6, !o.from_raw));
  std::int64_t last_t = t_first.value();
  for (std::size_t i = first; i < end; ++i) {
    std::vector<cv::Mat> images;
    for (auto& camera : cameras) {
      auto image = camera->next();
      if (!image) return fail(image.error());
      images.push_back(std::move(image.value()));
    }
    if (stop && stop->load()) return fail(Error{fmt::format("{}: stopped; nothing written", o.out.string())});
    auto picture = composer.value().compose(i, std::move(images));
    if (!picture) return fail(picture.error());
    auto t = sample_t(i);
    if (!t) return fail(t.error());
    const std::int64_t pts_us = std::int64_t(double(t.value() - t_first.value()) / o.speed / 1000.0);
    if (auto w = writer.value()->write(picture.value(), pts_us); !w) return fail(w.error());
    last_t = t.value();
    ++r.frames;
    if (progress) progress(i + 1 - first, end - first);
  }
  if (Status s = writer.value()->close(); !s.ok()) return fail(s.error());
  std::error_code ec;
  std::filesystem::rename(tmp, o.out, ec);
  if (ec) return fail(Error{fmt::format("{}: cannot move the rendering into place: {}", o.out.string(), ec.message())});
  // The last picture lasts one sample period, as in the session.
  const double period_s = r.frames > 1 ? double(last_t - t_first.value()) * 1e-9 / double(r.frames - 1) : 1.0 / 15;
  r.session_seconds = double(last_t - t_first.value()) * 1e-9 + period_s;
  r.video_seconds = r.session_seconds / o.speed;
  r.seconds_taken = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return r;
}

}  // namespace pvcap::replay
