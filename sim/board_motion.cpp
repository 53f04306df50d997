#include "sim/board_motion.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace pvcap::sim {

namespace {
cv::Matx33d rot_x(double a) { return {1, 0, 0, 0, std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a)}; }
cv::Matx33d rot_y(double a) { return {std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a)}; }
cv::Matx33d rot_z(double a) { return {std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1}; }
}  // namespace

BoardPose board_pose(int hold, double w, double h) {
  // A 4 x 4 lattice of places over and around the mat, visited three times at different heights,
  // tilted about both axes (so the focal length is seen in depth) and turned. Each round through
  // the 48 moves the places, heights, tilts and turns (round 0 is the lattice itself), as an operator
  // never holds the board the same way twice: a pose renders the same in every frame, so only a
  // pose not seen before tells the fit more.
  const int index = hold % kBoardPoses, round = hold / kBoardPoses;
  const int pass = index / 16, cell = index % 16;
  const double xs[4] = {-100.0, 40.0, 190.0, 330.0}, ys[4] = {-80.0, 20.0, 110.0, 210.0};
  const double heights[3] = {60.0, 150.0, 240.0};
  const double deg = 3.14159265358979 / 180.0;
  const double shift_x = round == 0 ? 0.0 : (round * 37 % 61) - 30.0;
  const double shift_y = round == 0 ? 0.0 : (round * 53 % 41) - 20.0;
  const double shift_h = round == 0 ? 0.0 : (round * 29 % 41) - 20.0;
  const double tilt = (40.0 - 5.0 * (round % 2)) * deg;
  const double tilt_x = ((cell + pass + round) % 3 - 1) * tilt;
  const double tilt_y = ((cell / 4 + cell + 2 * pass + 2 * round) % 3 - 1) * tilt;
  const double turn = ((cell * 7 + pass * 3 + round * 2) % 5 - 2) * 12.0 * deg;
  const cv::Vec3d centre(xs[cell % 4] + shift_x, ys[cell / 4] + shift_y, -(heights[pass] + shift_h));
  BoardPose p;
  p.R = rot_z(turn) * rot_x(tilt_x) * rot_y(tilt_y);
  p.t = centre - p.R * cv::Vec3d(w / 2, h / 2, 0);
  return p;
}

}  // namespace pvcap::sim

namespace pvcap::sim {

std::vector<int> board_session_holds(std::mt19937& rng, double lost_s, double duration_s, int holds) {
  const int samples = std::max(0, int((duration_s - lost_s) * 15.0));
  const int wanted = std::min(150, samples);
  std::uniform_real_distribution<double> jitter(-1.0 / 60, 1.0 / 60);
  std::vector<int> out;
  for (int k = 0; k < wanted; ++k) {
    const int sample = int(std::int64_t(k) * samples / wanted);
    const double t = lost_s + sample / 15.0 + jitter(rng);
    out.push_back(std::clamp(board_pose_index(std::max(0.0, t)), 0, holds - 1));
  }
  return out;
}

}  // namespace pvcap::sim
