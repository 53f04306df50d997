#include "sim/sim_rig.h"

#include "sim/netns.h"

#include <fstream>
#include <thread>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "calib/charuco.h"
#include "core/time.h"
#include "sim/board_motion.h"
#include "sim/scene.h"

namespace pvcap::sim {

std::vector<std::string> sim_addresses(const RigConfig& rig) {
  std::vector<std::string> out;
  for (const auto& c : rig.cameras)
    if (!c.address.empty()) out.push_back(c.address);
  return out;
}

Result<std::unique_ptr<SimRig>> SimRig::create(const RigConfig& rig, const std::filesystem::path& truth_dir,
                                               bool board, const std::string& light_off, double light_lag_s) {
  std::optional<SimConfig> sim;
  try {
    sim = load_sim_config(rig);
  } catch (const UserError& e) {
    return Error{e.what()};
  }
  if (!sim) return Error{fmt::format("{}: no 'sim:' section: this is not a simulated rig", rig.source.string())};
  std::error_code ec;
  std::filesystem::create_directories(truth_dir, ec);
  if (ec) return Error{fmt::format("cannot create {}: {}", truth_dir.string(), ec.message())};
  if (sim->replay) return create_replay(rig, *sim, truth_dir);
  std::unique_ptr<SimRig> self(new SimRig());
  self->rig_ = rig;
  self->sim_ = *sim;
  self->truth_dir_ = truth_dir;
  self->t0_ns_ = host_now().ns;
  self->hand_ = std::make_shared<Hand>(self->sim_.sensel);
  self->sim_.light_off = light_off;
  self->sim_.light_lag_s = light_lag_s;
  if (!rig.lights.empty() && !board)
    self->lights_ = std::make_shared<SimLights>(rig, light_off, light_lag_s, truth_dir);
  self->returned_.assign(rig.cameras.size(), 0);

  nlohmann::json truth;
  truth["t0_ns"] = self->t0_ns_;
  truth["clock"] = "CLOCK_MONOTONIC";
  const calib::PadLayout pad = calib::default_pad_layout();
  truth["pad"] = pad;
  if (board) {
    const calib::BoardSpec spec;
    truth["board"] = {{"squares", {spec.squares_x, spec.squares_y}},
                      {"square_mm", spec.square_mm},
                      {"marker_mm", spec.marker_mm},
                      {"poses", kBoardPoses},
                      {"hold_s", kBoardHoldSeconds}};
  }
  for (std::size_t i = 0; i < rig.cameras.size(); ++i) {
    const CameraConfig& cam = rig.cameras[i];
    const SimCameraClock& clk = self->sim_.cameras[i];
    const bool sensel_sim = rig.sensel && rig.sensel->tty == "sim";
    auto made = SimCamera::create(int(i), cam, clk, self->t0_ns_, self->sim_.seed, truth_dir,
                                  sensel_sim ? self->hand_ : nullptr, board, self->lights_);
    if (!made) return made.error();
    const calib::CameraModel model = made.value()->model({cam.width, cam.height});
    const cv::Matx33d h = calib::cells_to_ideal(model, pad);
    nlohmann::json corners;
    for (const cv::Point2d& p : calib::pad_corners_px(model, pad)) corners.push_back({p.x, p.y});
    nlohmann::json jc = {{"name", cam.name},
                         {"address", cam.address},
                         {"offset_ms", clk.offset_ms},
                         {"drift_ppm", clk.drift_ppm},
                         {"jitter_us", clk.jitter_us},
                         {"packet_loss", clk.packet_loss},
                         {"exposure_latency_ms", clk.exposure_latency_ms},
                         {"undeclared_latency_ms", clk.undeclared_latency_ms},
                         {"image_size", {cam.width, cam.height}},
                         {"model", model},
                         // pressure-image pixels (cell centres at integers) -> ideal (undistorted) pixels
                         {"cells_to_ideal_px", std::vector<double>(h.val, h.val + 9)},
                         // the grid's outer edges (0,0), (185,0), (185,105), (0,105) in the image as sent
                         {"pad_corners_px", corners}};
    if (clk.stop_after_s) jc["stop_after_s"] = *clk.stop_after_s;
    if (clk.return_after_s) jc["return_after_s"] = *clk.return_after_s;
    truth["cameras"].push_back(jc);
    self->cameras_.push_back(std::move(made.value()));
  }
  if (rig.sensel && rig.sensel->tty == "sim") {
    const SimSenselConfig& ss = self->sim_.sensel;
    self->sensel_truth_.open(truth_dir / "sensel_frames.csv");
    self->sensel_truth_ << "counter,true_ns,device_us\n";
    self->sensel_ = std::make_unique<SenselEmulator>(
        hand_scene(self->hand_),
        SenselClock{self->t0_ns_, ss.clock_start_us, ss.drift_ppm,
                    ss.clock_reset_at_s ? self->t0_ns_ + std::int64_t(*ss.clock_reset_at_s * 1e9) : INT64_MAX});
    if (ss.drop_fraction > 0) self->sensel_->set_drop_fraction(ss.drop_fraction, self->sim_.seed + 17);
    self->sensel_->set_truth_log(&self->sensel_truth_);
    if (Status s = self->serve_sensel(SenselLink{ss.usb_jitter_mean_ms, ss.usb_jitter_max_ms, self->sim_.seed});
        !s.ok())
      return s.error();
    truth["sensel"] = self->sensel_link();
    truth["sensel"].update({{"press_x_mm", ss.press_x_mm},
                            {"press_y_mm", ss.press_y_mm},
                            {"peak_grams", ss.peak_grams},
                            {"period_s", ss.period_s},
                            {"clock_start_us", ss.clock_start_us},
                            {"drift_ppm", ss.drift_ppm},
                            {"usb_jitter_mean_ms", ss.usb_jitter_mean_ms},
                            {"usb_jitter_max_ms", ss.usb_jitter_max_ms},
                            {"drop_fraction", ss.drop_fraction}});
    if (ss.clock_reset_at_s) truth["sensel"]["clock_reset_at_s"] = *ss.clock_reset_at_s;
  }
  std::ofstream(truth_dir / "rig.json") << truth.dump(2) << '\n';
  spdlog::info("sim: {} cameras serving ({}), ground truth in {}", self->cameras_.size(),
               fmt::join(sim_addresses(rig), ", "), truth_dir.string());
  return self;
}

Result<std::unique_ptr<SimRig>> SimRig::create_replay(const RigConfig& rig, const SimConfig& sim,
                                                      const std::filesystem::path& truth_dir) {
  auto opened = SessionReplay::open(*sim.replay, sim.replay_rate);
  if (!opened) return opened.error();
  std::unique_ptr<SimRig> self(new SimRig());
  self->rig_ = rig;
  self->sim_ = sim;
  self->truth_dir_ = truth_dir;
  self->t0_ns_ = host_now().ns;
  self->hand_ = std::make_shared<Hand>(self->sim_.sensel);
  self->replay_ = opened.value();
  nlohmann::json truth = {{"t0_ns", self->t0_ns_},
                          {"clock", "CLOCK_MONOTONIC"},
                          {"replay", std::filesystem::absolute(self->replay_->dir()).string()},
                          {"replay_rate", self->replay_->rate()}};
  for (const CameraConfig& cam : rig.cameras) {
    auto made = ReplayCamera::create(cam, self->replay_, truth_dir);
    if (!made) return made.error();
    self->replay_cameras_.push_back(std::move(made.value()));
    truth["cameras"].push_back({{"name", cam.name}, {"address", cam.address}});
  }
  if (rig.sensel && rig.sensel->tty == "sim") {
    if (!self->replay_->has_pressure())
      return Error{fmt::format("{}: the replayed session has no pressure frames, but the rig has a Sensel",
                               self->replay_->dir().string())};
    self->sensel_ = std::make_unique<SenselEmulator>(
        SenselScene{}, SenselClock{},
        self->replay_->sensel_serial().empty() ? SenselEmulator::kDefaultSerial : self->replay_->sensel_serial());
    self->sensel_->set_replay(self->replay_);
    self->sensel_truth_.open(truth_dir / "sensel_replay.csv");
    self->sensel_truth_ << "counter,device_us,due_ns,sent_ns,asked_ns,woke_ns\n";
    self->sensel_->set_truth_log(&self->sensel_truth_);
    if (Status s = self->serve_sensel(SenselLink{0, 0, 1}); !s.ok()) return s.error();
    truth["sensel"] = self->sensel_link();
    truth["sensel"].update(
        {{"frames", self->replay_->pressure_frames().size()}, {"serial", self->replay_->sensel_serial()}});
  }
  std::ofstream(truth_dir / "rig.json") << truth.dump(2) << '\n';
  spdlog::info("sim: replaying {} through {} cameras ({}){}", self->replay_->dir().string(),
               self->replay_cameras_.size(), fmt::join(sim_addresses(rig), ", "),
               self->sensel_ ? " and the Sensel" : "");
  return self;
}

void SimRig::steer(const HandCommand& c) {
  hand_->set(c);
  std::lock_guard lock(hand_truth_mu_);
  if (!hand_truth_.is_open()) {
    hand_truth_.open(truth_dir_ / "hand.csv");
    hand_truth_ << "from_ns,command\n";
  }
  hand_truth_ << c.from_ns << ',' << c.format() << '\n' << std::flush;
}

namespace {
// Aravis' fake camera engine notices its end at its next wait's end, up to 100 ms later: the
// cameras ended together wait once instead of once each in turn (a session's close waited for 4).
template <typename Camera>
void end_together(std::vector<std::unique_ptr<Camera>>& cameras) {
  std::vector<std::thread> ends;
  for (auto& camera : cameras)
    if (camera) ends.emplace_back([c = std::move(camera)]() mutable { c.reset(); });
  for (auto& t : ends) t.join();
  cameras.clear();
}
}  // namespace

SimRig::~SimRig() {
  sensel_pty_.reset();  // stops serving before the emulator goes
  sensel_usb_.reset();
  sensel_.reset();
  end_together(replay_cameras_);
  end_together(cameras_);
}

// Where the emulated Morph is served, for rig.json: its transport, pseudo-terminal or testbed.
nlohmann::json SimRig::sensel_link() const {
  return {{"transport", sim_.sensel.transport},
          {"tty", sensel_pty_ ? sensel_pty_->slave_path() : ""},
          {"usb", sensel_usb_ ? sensel_usb_->root_dir() : ""}};
}

// Serves sensel_ on a new pseudo-terminal and publishes it as truth_dir/<name> (atomically, so a
// driver reopening the link finds the old terminal or the new one, never none); or, with transport
// usb, on umockdev's emulated bus, its testbed published as truth_dir/sensel.usb.
Status SimRig::serve_sensel(SenselLink link, const std::string& name) {
  std::error_code ec;
  if (sim_.sensel.transport == "usb") {  // the recording finds the testbed through the link
    auto usb = SenselUsbDevice::create(*sensel_, link, {}, SenselUsbHost::OtherProcesses);
    if (!usb) return usb.error();
    sensel_usb_ = std::move(usb.value());
    const auto published = truth_dir_ / "sensel.usb";
    std::filesystem::create_symlink(sensel_usb_->root_dir(), published, ec);
    if (ec)
      return Error{fmt::format("cannot publish the emulated USB bus as {}: {}", published.string(), ec.message())};
    return {};
  }
  auto pty = SenselPty::create(*sensel_, link);
  if (!pty) return pty.error();
  sensel_pty_ = std::move(pty.value());
  const auto published = truth_dir_ / name, fresh = truth_dir_ / (name + ".new");
  std::filesystem::remove(fresh, ec);
  std::filesystem::create_symlink(sensel_pty_->slave_path(), fresh, ec);
  if (!ec) std::filesystem::rename(fresh, published, ec);
  if (ec)
    return Error{fmt::format("cannot publish the Sensel emulator's tty as {}: {}", published.string(), ec.message())};
  sensel_tty_link_ = published;
  return {};
}

// The Morph comes back power-cycled (its counter and clock restart) on a new pseudo-terminal, which
// the published link now names; as another Morph when the rig says so.
void SimRig::replug_sensel() {
  const SimSenselConfig& ss = sim_.sensel;
  const std::int64_t now = host_now().ns;
  sensel_ = std::make_unique<SenselEmulator>(hand_scene(hand_), SenselClock{now, 0.0, ss.drift_ppm},
                                             ss.replug_serial.value_or(SenselEmulator::kDefaultSerial));
  sensel_->set_truth_log(&sensel_truth_);
  // Renamed: the first name is gone, and the Morph appears under a name a udev rule would give it
  // (the driver finds it by its serial among such names).
  std::string name = "sensel.tty";
  if (ss.replug_renamed) {
    std::error_code ec;
    std::filesystem::remove(truth_dir_ / name, ec);
    name = "morph-replugged";
  }
  if (Status s = serve_sensel(SenselLink{ss.usb_jitter_mean_ms, ss.usb_jitter_max_ms, sim_.seed + 1}, name); !s.ok()) {
    spdlog::error("sim: the Sensel cannot come back: {}", s.error().message);
    return;
  }
  spdlog::warn("sim: the Sensel is plugged back in on {} ({}){}", sensel_pty_->slave_path(), name,
               ss.replug_serial ? " as another Morph (serial " + *ss.replug_serial + ")" : "");
}

void SimRig::run(const std::atomic<bool>& stop) {
  while (!stop.load()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    const double elapsed_s = double(host_now().ns - t0_ns_) / 1e9;
    const SimSenselConfig& ss = sim_.sensel;
    if ((sensel_pty_ || sensel_usb_) && ss.unplug_at_s && !sensel_unplugged_ && elapsed_s >= *ss.unplug_at_s) {
      sensel_unplugged_ = true;
      spdlog::warn("sim: the Sensel is unplugged now (unplug_at_s = {})", *ss.unplug_at_s);
      // As after a USB unplug, the device's name goes, then the device: the driver's tty reads fail and
      // its reopening finds nothing. Kept, the link would name a freed pseudo-terminal number, which the
      // kernel hands to the next one opened: in a suite run another rig's emulated Morph (same default
      // serial) was found there and taken for this one come back, before this one was plugged back in.
      if (sensel_pty_) {
        std::error_code ec;
        std::filesystem::remove(sensel_tty_link_, ec);
      }
      sensel_pty_.reset();
      if (sensel_usb_) sensel_usb_->unplug();
    }
    if (sensel_unplugged_ && !sensel_replugged_ && ss.replug_after_s && elapsed_s >= *ss.replug_after_s) {
      sensel_replugged_ = true;
      replug_sensel();
    }
    for (std::size_t i = 0; i < cameras_.size(); ++i) {
      const SimCameraClock& clk = sim_.cameras[i];
      // The k-th outage (from 0) runs from stop_after_s + k * outage_every_s to return_after_s + k * outage_every_s.
      const int k = returned_[i];
      const double shift = k * sim_.cameras[i].outage_every_s;
      const bool outage_left = k < (clk.return_after_s ? clk.outages : 1);
      if (cameras_[i] && clk.stop_after_s && outage_left && elapsed_s >= *clk.stop_after_s + shift) {
        spdlog::warn("sim: camera {} vanishes now (outage {} of {})", rig_.cameras[i].name, k + 1, clk.outages);
        cameras_[i].reset();
      }
      if (!cameras_[i] && clk.return_after_s && outage_left && elapsed_s >= *clk.return_after_s + shift) {
        ++returned_[i];
        const bool sensel_sim = rig_.sensel && rig_.sensel->tty == "sim";
        auto made = SimCamera::create(int(i), rig_.cameras[i], clk, t0_ns_, sim_.seed + 1, truth_dir_,
                                      sensel_sim ? hand_ : nullptr, false, lights_);
        if (made) {
          cameras_[i] = std::move(made.value());
          spdlog::warn("sim: camera {} is back (outage {} of {} over)", rig_.cameras[i].name, k + 1, clk.outages);
        } else {
          spdlog::error("sim: camera {} could not come back: {}", rig_.cameras[i].name, made.error().message);
        }
      }
    }
  }
}

Status ensure_network(const RigConfig& rig) {
  const auto addresses = sim_addresses(rig);
  if (addresses_present(addresses)) return {};
  return enter_private_network(addresses);
}

}  // namespace pvcap::sim
