#pragma once
// One simulated GigE Vision camera: Aravis' own fake-camera engine
// (ArvGvFakeCamera) serves real GVCP/GVSP on an address, while pvcap supplies
// the pixels (scene + timecode; a board session's without it) and the device clock (offset, drift,
// jitter).
// Every emitted frame is logged to a ground-truth CSV as it happens.
//
// It also has the GenICam timestamp latch real GigE cameras offer
// (sim/fake_camera_features.h).
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <thread>

#include <opencv2/core.hpp>

#include "calib/camera_model.h"
#include "capture/aravis_handles.h"
#include "core/result.h"
#include "core/rig_config.h"
#include "sim/board_frames.h"
#include "sim/engine_kicker.h"
#include "sim/gvsp_sender.h"
#include "sim/sim_config.h"

namespace pvcap::sim {

class Hand;
class SimLights;

struct SimClock {
  std::int64_t t0_ns = 0;  // true time (host CLOCK_MONOTONIC) taken as the device's power-on
  double offset_ns = 0;    // device time at t0
  double drift = 0;        // rate error (ppm * 1e-6)
  double jitter_ns = 0;    // std-dev of timestamp noise
  // The device timestamp a frame captured at true time `true_ns` carries (without noise).
  std::int64_t device_time(std::int64_t true_ns) const {
    return std::int64_t(offset_ns + double(true_ns - t0_ns) * (1.0 + drift));
  }
};

class SimCamera {
 public:
  // Serves `camera` (address must be an IPv4 address on this host) with `clock`.
  // Ground truth goes to `truth_dir/<name>_frames.csv`.
  // With `hand`, the camera also shows the simulated hand at each frame's instant; with `board`,
  // the ChArUco board of a board session (sim/board_motion.h) instead.
  static Result<std::unique_ptr<SimCamera>> create(int index, const CameraConfig& camera, const SimCameraClock& clock,
                                                   std::int64_t t0_ns, std::uint64_t seed,
                                                   const std::filesystem::path& truth_dir,
                                                   std::shared_ptr<const Hand> hand = nullptr, bool board = false,
                                                   std::shared_ptr<SimLights> lights = nullptr);
  ~SimCamera();
  SimCamera(const SimCamera&) = delete;
  SimCamera& operator=(const SimCamera&) = delete;

  const SimClock& clock() const { return clock_; }
  // The ground-truth camera model for images of `size`.
  calib::CameraModel model(cv::Size size) const;

 private:
  SimCamera() = default;
  static void fill(ArvBuffer* buffer, void* self, guint32 exposure_us, guint32 gain, ArvPixelFormat format);
  void fill_buffer(ArvBuffer* buffer, ArvPixelFormat format, std::int64_t exposure_ns);
  // A free-running camera's first frame of an acquisition waits for the engine's period grid, so
  // the next comes a whole period later (see the definition).
  void align_first_frame();
  void fill_at(ArvBuffer* buffer, ArvPixelFormat format, std::int64_t true_ns, std::int64_t exposure_ns);
  const cv::Mat& base_image(int width, int height, ArvPixelFormat format);
  // The scene as the rig's lamps lit at `true_ns` light it (the base image without lamps).
  const cv::Mat& lit_base(int width, int height, ArvPixelFormat format, std::uint32_t lamps);
  // With chunk mode on (SFNC 2 map), the frame goes out through our own sender with its chunks, the
  // engine's packets muted (sim/gvsp_sender.h); off, the engine sends it as before.
  void send_with_chunks(ArvBuffer* buffer, ArvPixelFormat format, std::int64_t exposure_ns);
  void wobble_exposure();

  int index_ = 0;
  std::string name_;
  SimCameraClock config_;
  cv::Size configured_size_;
  SimClock clock_;
  std::int64_t exposure_latency_ns_ = 0;
  std::int64_t undeclared_latency_ns_ = 0;  // the hand is drawn where it was this long before true_ns
  arv::GPtr<ArvGvFakeCamera> fake_;
  std::optional<GvspSender> sender_;  // on the fake camera's thread only
  double packet_loss_ = 0;            // the simulated link's, for the engine's packets and ours
  bool engine_muted_ = false;
  // exposure_wobble_us: the exposure the host set (the engine's register, until we move it), and what
  // we last wrote there.
  guint32 exposure_set_us_ = 0, exposure_written_us_ = 0;
  std::uint64_t wobbled_ = 0;
  std::atomic<std::int64_t> last_fill_ns_{0};  // when the engine last began a frame
  std::int64_t trigger_pending_since_ns_ = 0;  // the kicker's: when it saw a trigger pending
  std::unique_ptr<EngineKicker> kicker_;       // its stall, worked around (sim/engine_kicker.h)
  std::mutex mu_;                              // fill runs on the fake camera's thread; truth is read from others
  std::mt19937_64 rng_;
  std::normal_distribution<double> noise_{0.0, 1.0};
  std::map<std::tuple<int, int, std::uint32_t>, cv::Mat> bases_;
  std::ofstream truth_;
  std::uint64_t emitted_ = 0;
  std::shared_ptr<const Hand> hand_;
  bool board_ = false;
  // The rig's lamps (sim/lights.h): per image size their shading, per size, format and lamps lit the
  // scene so lit (at most 2^lamps images, each made once).
  std::shared_ptr<SimLights> lights_;
  std::map<std::pair<int, int>, std::vector<cv::Mat>> shading_;
  std::map<std::tuple<int, int, std::uint32_t, std::uint32_t>, cv::Mat> lit_;
  // Board sessions: per image size and format, the board's poses rendered ahead of the engine
  // (sim/board_frames.h).
  std::map<std::tuple<int, int, std::uint32_t>, std::unique_ptr<BoardFrames>> board_views_;
  cv::Mat board_image(int width, int height, ArvPixelFormat format, std::int64_t true_ns);
};

}  // namespace pvcap::sim
