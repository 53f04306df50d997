#include "sim/board_motion.h"

#include <cmath>

namespace pvcap::sim {

namespace {
cv::Matx33d rot_x(double a) { return {1, 0, 0, 0, std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a)}; }
cv::Matx33d rot_y(double a) { return {std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a)}; }
cv::Matx33d rot_z(double a) { return {std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1}; }
}  // namespace

BoardPose board_pose(int index, double w, double h) {
  index %= kBoardPoses;
  // A 4 x 4 lattice of places over and around the mat, visited three times at different heights,
  // tilted about both axes (so the focal length is seen in depth) and turned.
  const int pass = index / 16, cell = index % 16;
  const double xs[4] = {-100.0, 40.0, 190.0, 330.0}, ys[4] = {-80.0, 20.0, 110.0, 210.0};
  const double heights[3] = {60.0, 150.0, 240.0};
  const double deg = 3.14159265358979 / 180.0;
  const double tilt_x = ((cell + pass) % 3 - 1) * 40.0 * deg;
  const double tilt_y = ((cell / 4 + cell + 2 * pass) % 3 - 1) * 40.0 * deg;
  const double turn = ((cell * 7 + pass * 3) % 5 - 2) * 12.0 * deg;
  const cv::Vec3d centre(xs[cell % 4], ys[cell / 4], -heights[pass]);
  BoardPose p;
  p.R = rot_z(turn) * rot_x(tilt_x) * rot_y(tilt_y);
  p.t = centre - p.R * cv::Vec3d(w / 2, h / 2, 0);
  return p;
}

}  // namespace pvcap::sim
