#include "calib/camera_model.h"

#include <cmath>
#include <set>

#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>

namespace pvcap::calib {

CameraModel CameraModel::looking_at(cv::Size size, double focal_px, cv::Point2d principal,
                                    std::vector<double> distortion, cv::Point3d position, cv::Point3d target) {
  CameraModel m;
  m.image_size = size;
  m.K = cv::Matx33d(focal_px, 0, principal.x, 0, focal_px, principal.y, 0, 0, 1);
  m.distortion = std::move(distortion);
  const cv::Vec3d z = cv::normalize(cv::Vec3d(target - position));
  cv::Vec3d down(0, 1, 0);                                       // image rows follow +y...
  if (std::abs(z.dot(down)) > 0.99) down = cv::Vec3d(-1, 0, 0);  // ...unless looking along it
  const cv::Vec3d y = cv::normalize(down - z * z.dot(down));
  const cv::Vec3d x = y.cross(z);
  m.R = cv::Matx33d(x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]);
  m.t = -(m.R * cv::Vec3d(position));
  return m;
}

cv::Mat CameraModel::distortion_mat() const {
  return distortion.empty() ? cv::Mat() : cv::Mat(distortion, true).reshape(1, 1);
}

cv::Point2d CameraModel::project(const cv::Point3d& p) const {
  std::vector<cv::Point2d> out;
  cv::Vec3d rvec;
  cv::Rodrigues(R, rvec);
  cv::projectPoints(std::vector<cv::Point3d>{p}, rvec, t, K, distortion_mat(), out);
  return out[0];
}

cv::Point2d CameraModel::project_ideal(const cv::Point3d& p) const {
  const cv::Vec3d c = R * cv::Vec3d(p) + t;
  const cv::Vec3d q = K * c;
  return {q[0] / q[2], q[1] / q[2]};
}

cv::Matx33d CameraModel::pad_to_ideal() const {
  const cv::Matx33d rt(R(0, 0), R(0, 1), t[0], R(1, 0), R(1, 1), t[1], R(2, 0), R(2, 1), t[2]);
  return K * rt;
}

cv::Point3d CameraModel::centre_mm() const {
  const cv::Vec3d c = -(R.t() * t);
  return {c[0], c[1], c[2]};
}

std::vector<cv::Point2d> CameraModel::undistort(const std::vector<cv::Point2d>& pixels) const {
  if (pixels.empty() || distortion.empty()) return pixels;
  std::vector<cv::Point2d> out;
  // OpenCV's default stops after 5 iterations: not enough at the corners of a wide lens.
  cv::undistortPoints(pixels, out, K, distortion_mat(), cv::noArray(), K,
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-10));
  return out;
}

cv::Mat CameraModel::normalised_rays() const {
  // Undistorting every pixel iteratively costs about a second at 1080p; the rays vary smoothly,
  // so they are undistorted on a 4 px lattice and interpolated in between (error < 0.001 px on
  // pvcap's simulated lenses; the unit test checks).
  constexpr int kStep = 4;
  const int gw = (image_size.width - 1) / kStep + 2, gh = (image_size.height - 1) / kStep + 2;
  std::vector<cv::Point2f> nodes;
  nodes.reserve(std::size_t(gw * gh));
  for (int j = 0; j < gh; ++j)
    for (int i = 0; i < gw; ++i) nodes.emplace_back(float(i * kStep), float(j * kStep));
  std::vector<cv::Point2f> rays;
  cv::undistortPoints(nodes, rays, K, distortion_mat(), cv::noArray(), cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 1e-9));
  cv::Mat out(image_size, CV_32FC2);
  for (int y = 0; y < image_size.height; ++y) {
    const int j = y / kStep;
    const float fy = float(y - j * kStep) / kStep;
    auto* row = out.ptr<cv::Vec2f>(y);
    for (int x = 0; x < image_size.width; ++x) {
      const int i = x / kStep;
      const float fx = float(x - i * kStep) / kStep;
      const cv::Point2f& a = rays[std::size_t(j * gw + i)];
      const cv::Point2f& b = rays[std::size_t(j * gw + i + 1)];
      const cv::Point2f& c = rays[std::size_t((j + 1) * gw + i)];
      const cv::Point2f& d = rays[std::size_t((j + 1) * gw + i + 1)];
      const cv::Point2f p = (a * (1 - fx) + b * fx) * (1 - fy) + (c * (1 - fx) + d * fx) * fy;
      row[x] = cv::Vec2f(p.x, p.y);
    }
  }
  return out;
}

cv::Matx33d cells_to_ideal(const CameraModel& m, const PadLayout& pad) {
  const cv::Matx33d cell_to_mm(pad.pitch_mm, 0, 0, 0, pad.pitch_mm, 0, 0, 0, 1);
  cv::Matx33d h = m.pad_to_ideal() * cell_to_mm;
  return h * (1.0 / h(2, 2));
}

std::array<cv::Point2d, 4> pad_corners_px(const CameraModel& m, const PadLayout& pad) {
  std::array<cv::Point2d, 4> out;
  const auto corners = pad.grid_corners_mm();
  for (std::size_t i = 0; i < 4; ++i) out[i] = m.project({corners[i].x, corners[i].y, 0.0});
  return out;
}

std::vector<double> flat(const cv::Matx33d& m) { return {m.val, m.val + 9}; }

namespace {
cv::Matx33d matx(const nlohmann::json& j) {
  const auto v = j.get<std::vector<double>>();
  if (v.size() != 9) throw nlohmann::json::other_error::create(501, "a 3x3 matrix needs 9 numbers", &j);
  return cv::Matx33d(v.data());
}
}  // namespace

void to_json(nlohmann::json& j, const CameraModel& m) {
  cv::Vec3d rvec;
  cv::Rodrigues(m.R, rvec);
  const cv::Point3d c = m.centre_mm();
  j = {{"image_size", {m.image_size.width, m.image_size.height}},
       {"K", flat(m.K)},
       {"fx", m.K(0, 0)},
       {"fy", m.K(1, 1)},
       {"cx", m.K(0, 2)},
       {"cy", m.K(1, 2)},
       {"distortion", m.distortion},
       {"R", flat(m.R)},
       {"rvec", {rvec[0], rvec[1], rvec[2]}},
       {"t_mm", {m.t[0], m.t[1], m.t[2]}},
       {"centre_mm", {c.x, c.y, c.z}}};
}

void from_json(const nlohmann::json& j, CameraModel& m) {
  auto fail = [&](const char* what) { throw nlohmann::json::other_error::create(501, what, &j); };
  const auto size = j.at("image_size").get<std::vector<double>>();
  if (size.size() != 2 || !(size[0] >= 1 && size[0] <= 100000) || !(size[1] >= 1 && size[1] <= 100000))
    fail("image_size must be [width, height] in pixels");
  m.image_size = {int(size[0]), int(size[1])};
  m.K = matx(j.at("K"));
  m.distortion = j.at("distortion").get<std::vector<double>>();
  static const std::set<std::size_t> counts = {0, 4, 5, 8, 12, 14};  // what OpenCV's models take
  if (!counts.count(m.distortion.size())) fail("distortion must have 0, 4, 5, 8, 12 or 14 coefficients");
  m.R = matx(j.at("R"));
  const auto t = j.at("t_mm").get<std::vector<double>>();
  if (t.size() != 3) fail("t_mm needs 3 numbers");
  m.t = {t[0], t[1], t[2]};
  for (double v : m.K.val)
    if (!std::isfinite(v)) fail("K must be finite");
  if (!(m.K(0, 0) > 0 && m.K(1, 1) > 0)) fail("K's focal lengths must be positive");
  for (double v : m.distortion)
    if (!std::isfinite(v)) fail("distortion must be finite");
  for (double v : m.R.val)
    if (!std::isfinite(v)) fail("R must be finite");
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(m.t[k])) fail("t_mm must be finite");
}

}  // namespace pvcap::calib
