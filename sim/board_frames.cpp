#include "sim/board_frames.h"

#include <iterator>

#include <opencv2/imgproc.hpp>

#include "calib/charuco.h"
#include "calib/pad_layout.h"
#include "sim/board_motion.h"
#include "sim/scene.h"

namespace pvcap::sim {

namespace {
const calib::BoardSpec& board_spec() {
  static const calib::BoardSpec spec;
  return spec;
}

const PlaneTexture& board_texture() {
  static const PlaneTexture board = [] {
    constexpr double kPxPerMm = 6.0;
    cv::Mat bgr;
    cv::cvtColor(calib::board_image(board_spec(), kPxPerMm), bgr, cv::COLOR_GRAY2BGR);
    return PlaneTexture{bgr, cv::Matx33d(kPxPerMm, 0, -0.5, 0, kPxPerMm, -0.5, 0, 0, 1)};
  }();
  return board;
}
}  // namespace

BoardFrames::BoardFrames(const calib::CameraModel& model, std::string pixel_format, int first_pose)
    : model_(model), pixel_format_(std::move(pixel_format)) {
  (void)board_texture();  // made once, before two threads could race to its static
  rays_ = model_.normalised_rays();
  scene_bgr_ = render_scene_bgr(calib::default_pad_layout(), model_, rays_);
  frames_.emplace(first_pose, render(first_pose));
  shown_ = wanted_ = first_pose;
  poses_shown_ = 1;
  thread_ = std::thread([this] { run(); });
}

BoardFrames::~BoardFrames() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

cv::Mat BoardFrames::render(int pose) const {
  const BoardPose p = board_pose(pose, board_spec().width_mm(), board_spec().height_mm());
  cv::Mat bgr = scene_bgr_.clone();
  draw_plane(bgr, rays_, model_.R * p.R, model_.R * p.t + model_.t, board_texture());
  return to_sensor_format(bgr, pixel_format_);
}

cv::Mat BoardFrames::frame(int pose) {
  std::lock_guard lock(mu_);
  if (pose > shown_) {
    // The newest rendered pose up to `pose`. Only `pose` itself, as it once was, held the board still
    // for a whole session when every render took longer than a pose lasts: each finished after the
    // engine had moved on (a loaded suite run's board session: three cameras saw 0-5 distinct views).
    if (auto newest = frames_.upper_bound(pose); newest != frames_.begin() && std::prev(newest)->first > shown_) {
      --newest;
      shown_ = newest->first;
      ++poses_shown_;
      frames_.erase(frames_.begin(), newest);
    }
    if (pose > wanted_) {
      wanted_ = pose;
      wake_.notify_one();
    }
  }
  return frames_.at(shown_);
}

bool BoardFrames::rendered(int pose) const {
  std::lock_guard lock(mu_);
  return pose > shown_ && frames_.count(pose) > 0;
}

int BoardFrames::poses_shown() const {
  std::lock_guard lock(mu_);
  return poses_shown_;
}

void BoardFrames::run() {
  std::unique_lock lock(mu_);
  while (!stop_) {
    // The pose wanted now, else the one after it: never more than one ahead of the engine.
    int todo = -1;
    for (int pose : {wanted_, wanted_ + 1})
      if (pose > shown_ && !frames_.count(pose)) {
        todo = pose;
        break;
      }
    if (todo < 0) {
      wake_.wait(lock);
      continue;
    }
    lock.unlock();
    cv::Mat frame = render(todo);
    lock.lock();
    if (todo > shown_) frames_.emplace(todo, std::move(frame));
  }
}

}  // namespace pvcap::sim
