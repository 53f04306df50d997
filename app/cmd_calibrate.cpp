// `pvcap calibrate board|intrinsics|pad|check` (calib/session_calibration.h): its results printed as
// they come, each camera's failure on stderr, progress on the terminal. The reference a
// calibration is compared against is loaded here: `--ground-truth` a simulated run's sim-truth/
// (the simulator's own record of its lenses and poses), or `--reference` an earlier rig calibration.
#include <fmt/format.h>

#include "app/command.h"
#include "calib/rig_calibration.h"
#include "calib/session_calibration.h"
#include "console/progress_line.h"
#include "sim/truth.h"

namespace pvcap {

namespace {

calib::ReferenceCalibration reference_from_truth(const std::filesystem::path& truth_dir) {
  auto truth = sim::read_rig_truth(truth_dir);
  if (!truth) throw UserError(truth.error().message);
  calib::ReferenceCalibration r;
  r.label = "the truth";
  for (const auto& c : truth.value().cameras) r.cameras.push_back({c.name, c.model, c.pad_corners_px});
  return r;
}

calib::ReferenceCalibration reference_from_file(const std::filesystem::path& file) {
  auto loaded = calib::load_rig_calibration(file);
  if (!loaded) throw UserError(loaded.error().message);
  return calib::reference_from(loaded.value(), file.string());
}

}  // namespace

Registered add_calibrate_command(CLI::App& app, AppContext&) {
  struct Args {
    calib::SessionCalibrationOptions o;
    std::string rig, ground_truth, reference, board_out;
  };
  auto a = std::make_shared<Args>();
  auto* calibrate = app.add_subcommand("calibrate",
                                       "camera intrinsics from a board session, the pad's pose and "
                                       "homography from any session showing the mat");
  calibrate->require_subcommand(1);
  auto* board = calibrate->add_subcommand("board", "write the ChArUco board to print (.pdf or .png)");
  board->add_option("--out", a->board_out, "board.pdf or board.png")->required();
  auto* intrinsics = calibrate->add_subcommand("intrinsics",
                                               "each camera's lens from a board session "
                                               "(pvcap session --board)");
  auto* pad = calibrate->add_subcommand("pad",
                                        "the pad's pose and homography in each camera from the mat's markers, "
                                        "with the intrinsics of a calibration file");
  auto* check = calibrate->add_subcommand("check",
                                          "the press check: each press's pressure centroid against the "
                                          "fingertip seen in each camera, through the calibration");
  for (auto* c : {intrinsics, pad, check}) {
    c->add_option("SESSION", a->o.session, "the session folder")->required()->check(CLI::ExistingDirectory);
    c->add_option("--rig", a->rig,
                  "the rig file: the calibration file defaults to <rig>.calibration.yaml beside it "
                  "(otherwise SESSION/calibration.yaml)")
        ->check(CLI::ExistingFile);
    c->add_option("--frames", a->o.frames, "frames per camera to look at, spread over the session")
        ->check(CLI::Range(1, 100000));
  }
  for (auto* c : {intrinsics, pad}) {
    auto* truth = c->add_option("--ground-truth", a->ground_truth,
                                "a simulated run's sim-truth folder: print the "
                                "errors against it and exit 1 above target")
                      ->check(CLI::ExistingDirectory);
    c->add_option("--reference", a->reference,
                  "an earlier rig calibration file: print the errors against it and "
                  "exit 1 above target")
        ->check(CLI::ExistingFile)
        ->excludes(truth);
  }
  intrinsics->add_option("--out", a->o.calibration, "the calibration file to write (updated if it exists)");
  intrinsics->add_option("--save-views", a->o.save_views,
                         "also write each camera's board views (the corners found) to DIR/<camera>.board-views.yaml, "
                         "to fit them again elsewhere (build/bench/board_fit_bench --views FILE)");
  pad->add_option("--calibration", a->o.calibration,
                  "the calibration file with the intrinsics (updated with the "
                  "pose)");
  check->add_option("--calibration", a->o.calibration, "the calibration file to check");
  return {calibrate, [a, board, intrinsics, pad, check] {
            if (*board) return fmt::print("{}", calib::write_board(a->board_out)), 0;
            console::ProgressLine bar;
            a->o.sinks = {[](const std::string& text) { fmt::print("{}", text); },
                          [](const std::string& line) { fmt::print(stderr, "pvcap: {}\n", line); },
                          [&bar](const std::string& what, std::size_t done, std::size_t total) {
                            bar.show(fmt::format("{}: {}/{} frames", what, done, total), done, total);
                          }};
            if (a->o.calibration.empty() && !a->rig.empty()) a->o.calibration = calib::default_calibration_path(a->rig);
            if (!a->ground_truth.empty()) a->o.reference = reference_from_truth(a->ground_truth);
            if (!a->reference.empty()) a->o.reference = reference_from_file(a->reference);
            (void)intrinsics;
            const bool ok = *check ? calib::check_against_presses(a->o)
                            : *pad ? calib::pad_from_session(a->o)
                                   : calib::intrinsics_from_session(a->o);
            return ok ? 0 : 1;  // 1: a camera failed or missed its target (what succeeded is saved)
          }};
}

}  // namespace pvcap
