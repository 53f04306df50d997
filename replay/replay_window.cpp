#include "replay/replay_window.h"

#include <cstdlib>

#include <fmt/format.h>
#include <opencv2/highgui.hpp>
#include <opencv2/imgproc.hpp>

#include "codec/image_files.h"
#include "core/time.h"
#include "replay/replay_composer.h"
#include "replay/replay_player.h"
#include "storage/index/session_reader.h"

namespace pvcap::replay {

namespace {
constexpr int kStatusHeight = 34;

// The picture with a status line under it: what is shown and how to steer.
cv::Mat with_status(const cv::Mat& picture, const ReplayPlayer& player, std::int64_t t_s_ns) {
  cv::Mat out(picture.rows + kStatusHeight, picture.cols, CV_8UC3, cv::Scalar(30, 30, 30));
  picture.copyTo(out(cv::Rect(0, 0, picture.cols, picture.rows)));
  const std::string state =
      player.playing() ? fmt::format("PLAYING {:g}x", player.speed()) : fmt::format("PAUSED  {:g}x", player.speed());
  const std::string where =
      fmt::format("sample {} of {}   {:.2f} s", player.position(), player.size(), double(t_s_ns) / 1e9);
  const int y = picture.rows + 23;
  cv::putText(out, state, {12, y}, cv::FONT_HERSHEY_SIMPLEX, 0.65,
              player.playing() ? cv::Scalar(120, 230, 120) : cv::Scalar(90, 200, 255), 2, cv::LINE_AA);
  cv::putText(out, where, {200, y}, cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(235, 235, 235), 1, cv::LINE_AA);
  cv::putText(out, key_help(), {520, y}, cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(190, 190, 190), 1, cv::LINE_AA);
  return out;
}
}  // namespace

Result<WindowSummary> run_replay_window(const std::filesystem::path& session, const WindowOptions& options,
                                        const std::atomic<bool>* stop) {
  auto reader = SessionReader::open(session);
  if (!reader) return reader.error();
  auto composer = ReplayComposer::open(*reader.value(), session, options.pressure_full_scale_kpa);
  if (!composer) return composer.error();
  composer.value().set_view_videos(!options.from_raw);
  auto infos = reader.value()->sample_infos();
  if (!infos) return infos.error();
  if (infos.value().empty()) return Error{fmt::format("{}: the session has no samples to show", session.string())};
  const std::int64_t start_ns = reader.value()->info().started_host_ns;
  std::vector<std::int64_t> times;
  for (const auto& s : infos.value()) times.push_back(s.t_ns);
  ReplayPlayer player(std::move(times), composer.value().take_starts());

  const std::string title = fmt::format("pvcap replay - {}", session.filename().string());
  cv::namedWindow(title, cv::WINDOW_NORMAL | cv::WINDOW_KEEPRATIO | cv::WINDOW_GUI_NORMAL);
  cv::resizeWindow(title, Layout::kWidth, Layout::kHeight + kStatusHeight);
  WindowSummary summary;
  std::size_t shown = SIZE_MAX;
  bool was_playing = false;
  double was_speed = 0;
  cv::Mat picture, last;
  std::size_t scripted = 0;
  while (!player.quit() && !(stop && stop->load())) {
    player.tick(host_now().ns);
    const std::size_t i = player.position();
    if (i != shown || player.playing() != was_playing || player.speed() != was_speed) {
      if (i != shown) {
        auto composed = composer.value().compose(i);
        if (composed) {
          picture = std::move(composed.value());
        } else {  // a sample that cannot be drawn says why, and the replay goes on
          picture = cv::Mat(Layout::kHeight, Layout::kWidth, CV_8UC3, cv::Scalar(0, 0, 0));
          cv::putText(picture, composed.error().message.substr(0, 120), {20, Layout::kHeight / 2},
                      cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(80, 80, 255), 1, cv::LINE_AA);
        }
        ++summary.pictures;
      }
      last = with_status(picture, player, infos.value()[i].t_ns - start_ns);
      cv::imshow(title, last);
      shown = i, was_playing = player.playing(), was_speed = player.speed();
    }
    if (scripted < options.keys.size()) {
      (void)cv::waitKey(1);  // let the window draw
      player.press(key_from_name(options.keys[scripted++]), host_now().ns);
      continue;
    }
    const int code = cv::waitKeyEx(player.wait_ms(host_now().ns));
    if (cv::getWindowProperty(title, cv::WND_PROP_VISIBLE) < 1) break;  // closed by the window manager
    player.press(key_from_code(code), host_now().ns);
  }
  summary.last_sample = shown;
  if (!options.snapshot.empty() && !last.empty())
    if (Status s = write_image(options.snapshot, last); !s.ok()) return s.error();
  cv::destroyAllWindows();
  return summary;
}

}  // namespace pvcap::replay
