#pragma once
// The simulated rig's lights (the rig file's `lights:`): each a lamp above the table, switched by the
// output line of the simulated camera that drives it, as a real rig's lamps are by their cameras'
// lines (docs/cameras.md, "Lights"). Every camera's image is shaded by the lamps lit at its frame's
// instant: the pad, mat and hand brighter under a lamp, and brightest near it.
//
// A camera's feature service (sim/fake_camera_features.h) reports its lines' outputs as the host sets
// them; SimLights turns them into lamps lit or dark, with the faults a lab meets:
// `PVCAP_FAULTS=sim.light_off=C` (a lamp that never comes on) and `sim.light_lag_s=S` (every lamp
// reaches its new state S seconds after its line). Each lamp's changes go to truth_dir/lights.csv.
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "calib/camera_model.h"
#include "core/rig_config.h"

namespace pvcap::sim {

struct SimLamp {
  std::string name;  // the lighting code's letter
  int camera = 0;    // the rig camera whose line drives it
  int line = 0;      // that camera's LineN
  cv::Point3d position_mm;  // above the pad (pad frame; z up from the pad)
  double intensity = 1;     // its share of the light at the pad's centre
};

// Where the lamps hang when the rig does not say: L to the participant's left, C above the far edge,
// R to the right, all about half a metre above the table.
cv::Point3d default_lamp_position(const std::string& name, std::size_t index);

class SimLights {
 public:
  // `off`: the letters of lamps that never light; `lag_s`: how late every lamp follows its line.
  SimLights(const RigConfig& rig, std::string off, double lag_s, const std::filesystem::path& truth_dir);

  const std::vector<SimLamp>& lamps() const { return lamps_; }
  bool empty() const { return lamps_.empty(); }

  // Camera `camera`'s output lines as the host has set them (bit N: LineN drives its lamp on).
  void outputs(int camera, std::uint32_t line_mask, std::int64_t host_ns);
  // The lamps lit at a host instant (bit i: lamps()[i]).
  std::uint32_t lit_at(std::int64_t host_ns) const;

 private:
  struct Change {
    std::int64_t at_ns;
    std::uint32_t mask;
  };
  std::vector<SimLamp> lamps_;
  std::string off_;
  std::int64_t lag_ns_ = 0;
  mutable std::mutex mu_;
  std::vector<std::uint32_t> camera_lines_;  // per rig camera, its lines' last outputs
  std::uint32_t driven_ = 0;                 // the lamps the lines drive now
  std::vector<Change> changes_;              // the lamps' states from each instant on (lag applied)
  std::ofstream truth_;
};

// How much light each lamp gives each pixel of a camera's view (relative to the pad centre's share
// when every lamp is lit), at a quarter of the image's size: CV_32F, one per lamp.
std::vector<cv::Mat> lamp_shading(const calib::CameraModel& camera, const std::vector<SimLamp>& lamps);
// The room's light without any lamp, as a share of all lamps lit.
inline constexpr double kAmbientLight = 0.3;
// `image` (a sensor-format frame: Bayer, Mono8 or RGB8) as lit by the lamps in `mask`: each pixel
// scaled by the ambient light plus the lit lamps' shading there.
cv::Mat lit_image(const cv::Mat& image, const std::vector<cv::Mat>& shading, std::uint32_t mask);
// The light falling on one pixel (for what is drawn after: the fingertip).
double light_at(const std::vector<cv::Mat>& shading, std::uint32_t mask, cv::Point2d pixel, cv::Size image_size);

}  // namespace pvcap::sim
