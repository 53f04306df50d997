// The PressureVisionDB export end to end: a simulated protocol session, its pad calibrated, exported
// in both layouts and read back by a Python script that knows only the layout's contract (json,
// pickle, numpy, OpenCV): every sequence and frame is there, the force is the store's, the loaders'
// own homography puts the grid's corners within 3 px of the simulator's truth (PV++'s per-frame
// homographies within 0.5 px), and an interrupted export resumes.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/rig_calibration.h"
#include "codec/sensel_units.h"
#include "session_under_test.h"
#include "sim/truth.h"
#include "storage/index/database.h"
#include "storage/index/session_reader.h"
#include "tests/integration/export_fixture.h"
#include "tests/integration/picture_files.h"

namespace fs = std::filesystem;
using pvcap::testing::only_session;
using namespace pvcap::testing;
using nlohmann::json;

namespace {

// Runs a command and returns its stdout.
std::string output_of(const std::string& command) {
  std::string out;
  FILE* p = popen(command.c_str(), "r");
  if (!p) return out;
  char buf[65536];
  while (std::size_t n = fread(buf, 1, sizeof buf, p)) out.append(buf, n);
  pclose(p);
  return out;
}

json read_back(const fs::path& dir, const fs::path& session) {
  const std::string out = output_of(
      fmt::format("/usr/bin/python3 {} {} {}",
                  (fs::path(PVCAP_SOURCE_DIR) / "tests" / "integration" / "read_pressurevision_export.py").string(),
                  dir.string(), (session / "sim-truth" / "rig.json").string()));
  return json::parse(out, nullptr, false);
}

// The store's own pressure of a sample in kPa summed over the 185 x 105 sensels (the documented
// expansion and units, codec/sensel_units.h).
double store_kpa_sum(pvcap::SessionReader& r, std::size_t sample) {
  auto info = r.sample_info(sample);
  auto frame = r.pressure_frame(info.value().pressure->sequence);
  const auto& f = frame.value();
  const pvcap::sensel::Grid g{f.grid_cols, f.grid_rows, f.grid_xscale, f.grid_yscale};
  double sum = 0;
  for (float v : pvcap::sensel::upsample(f.counts, g)) sum += pvcap::sensel::upsampled_sensel_kpa(v, g);
  return sum;
}

}  // namespace

TEST(Export, ThePressureVisionLayoutReadsBackAsTheLoadersReadIt) {
  const Recorded& rec = recorded();
  ASSERT_FALSE(rec.session.empty());
  const fs::path out = rec.work / "pv";
  const auto run =
      run_pvcap(fmt::format("export {} --layout pressurevision --out {}", rec.session.string(), out.string()));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const json back = read_back(out, rec.session);
  ASSERT_TRUE(back.is_object()) << "the Python reader failed";
  EXPECT_EQ(back["participants"]["P017"], "0001_P017");

  const auto takes =
      json::parse(run_pvcap(fmt::format("--log-level warn takes {} --json", rec.session.string())).output);
  ASSERT_EQ(back["sequences"].size(), takes["takes"].size()) << "every done take is a sequence";
  auto reader = pvcap::SessionReader::open(rec.session);
  ASSERT_TRUE(reader) << reader.error().message;
  for (const auto& seq : back["sequences"]) {
    SCOPED_TRACE(seq["sequence"].get<std::string>());
    EXPECT_EQ(seq["participant"], "0001_P017");
    EXPECT_EQ(seq["participant_keys"]["Skintone"], "dark");
    EXPECT_EQ(seq["participant_keys"]["Light Direction"], "left right");
    EXPECT_EQ(seq["image_size"], json::array({960, 540}));
    // The take's samples, every one (the simulated rig loses none), in order on the session clock.
    const json* take = nullptr;
    for (const auto& t : takes["takes"])
      if (t["sequence"] == seq["sequence"]) take = &t;
    ASSERT_NE(take, nullptr);
    const std::size_t first = (*take)["first_sample"], end = (*take)["end_sample"];
    const std::size_t n = seq["num_frames"];
    // Every sample of the take is a frame, or counted as left out (a camera's frame or the pressure
    // missing: the cameras share a trigger line, but a loaded machine can still lose an instant).
    const json meta = json::parse(
        read_all(out / seq["participant"].get<std::string>() / seq["sequence"].get<std::string>() / "metadata.json"));
    EXPECT_EQ(n + meta["pvcap"]["samples_left_out"].get<std::size_t>(), end - first);
    EXPECT_GT(n, (end - first) / 2) << "the recorded session's report:\n" << read_all(rec.session / "report.txt");
    for (std::size_t t = 1; t < n; ++t)
      EXPECT_GT(seq["timesteps"][t].get<double>(), seq["timesteps"][t - 1].get<double>());
    // The force the loaders compute is the store's pressure: compare each frame with the sample at its time.
    for (std::size_t t = 0; t < n; ++t) {
      const std::int64_t at =
          reader.value()->info().started_host_ns + std::llround(seq["timesteps"][t].get<double>() * 1e9);
      auto i = reader.value()->sample_at(at);
      ASSERT_TRUE(i);
      const double expected = store_kpa_sum(*reader.value(), i.value());
      EXPECT_NEAR(seq["force_kpa_sums"][t].get<double>(), expected, 1e-4 * std::max(1.0, expected)) << t;
    }
    // The loaders' homography (their 235 x 135 mm pad through the exported pose) lands on the grid.
    for (const auto& [camera, px] : seq["corner_error_px"].items()) EXPECT_LT(px.get<double>(), 3.0) << camera;
  }
  // The residual of that fit is reported per camera.
  EXPECT_NE(run.output.find("the loaders' pad corners lie"), std::string::npos) << run.output;
  std::printf("%s", run.output.c_str());
  // Every file has its checksum, and the metadata says where it came from.
  for (const auto& seq : back["sequences"]) {
    const fs::path dir = out / seq["participant"].get<std::string>() / seq["sequence"].get<std::string>();
    const json manifest = json::parse(read_all(dir / "manifest.json"));
    EXPECT_EQ(manifest["files"].size(), seq["num_frames"].get<std::size_t>() * 5 + 1);  // 4 cameras, force, source
    const json meta = json::parse(read_all(dir / "metadata.json"));
    EXPECT_EQ(meta["pvcap"]["take"]["sequence"], seq["sequence"]);
  }
  // Again: everything is found, nothing rewritten.
  const auto again =
      run_pvcap(fmt::format("export {} --layout pressurevision --out {}", rec.session.string(), out.string()));
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find("(0 written now"), std::string::npos) << again.output;
}

TEST(Export, ThePressureVisionPlusLayoutHasAnExactHomographyPerFrame) {
  const Recorded& rec = recorded();
  ASSERT_FALSE(rec.session.empty());
  const fs::path out = rec.work / "pvplus";
  const auto run = run_pvcap(fmt::format("export {} --layout pressurevision-plus --out {} --jpeg-quality 80",
                                         rec.session.string(), out.string()));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const json back = read_back(out, rec.session);
  ASSERT_TRUE(back.is_object());
  ASSERT_FALSE(back["sequences"].empty());
  for (const auto& seq : back["sequences"]) {
    ASSERT_EQ(seq["corner_error_px"].size(), 4u);
    for (const auto& [camera, px] : seq["corner_error_px"].items()) EXPECT_LT(px.get<double>(), 0.5) << camera;
  }
}

TEST(Export, OneTakeSomeCamerasAndNpyForce) {
  const Recorded& rec = recorded();
  ASSERT_FALSE(rec.session.empty());
  const fs::path out = rec.work / "one-take";
  const std::string take = "press_index_finger_high_2x_right";
  const auto run = run_pvcap(fmt::format("export {} --out {} --take {} --cameras 0 3 --force-format npy",
                                         rec.session.string(), out.string(), take));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const fs::path participant = out / "0001_P017";
  std::size_t sequences = 0;
  for (const auto& e : fs::directory_iterator(participant)) sequences += e.is_directory();
  EXPECT_EQ(sequences, 1u);
  const fs::path dir = participant / take;
  const json meta = json::parse(read_all(dir / "metadata.json"));
  EXPECT_EQ(meta["num_cameras"], 2);
  EXPECT_EQ(meta["pvcap"]["cameras"][0]["name"], "cam0");
  EXPECT_EQ(meta["pvcap"]["cameras"][1]["name"], "cam3");
  EXPECT_TRUE(fs::exists(dir / "camera_1" / "00000.jpg"));
  EXPECT_FALSE(fs::exists(dir / "camera_2"));
  EXPECT_TRUE(fs::exists(dir / "force" / "00000.npy"));
  const std::string npy =
      output_of(fmt::format("/usr/bin/python3 -c \"import numpy; a = numpy.load('{}'); print(a.shape, a.dtype)\"",
                            (dir / "force" / "00000.npy").string()));
  EXPECT_EQ(npy, "(105, 185) float32\n");
}

TEST(Export, AnInterruptedExportResumesAndMistakesAreNamed) {
  const Recorded& rec = recorded();
  ASSERT_FALSE(rec.session.empty());
  const fs::path out = rec.work / "resume";
  // Killed mid-way: only whole files are left, and the second run completes the rest.
  const pid_t pid =
      spawn_pvcap(fmt::format("export {} --layout pressurevision --out {}", rec.session.string(), out.string()),
                  rec.work / "export-killed.log");
  for (int i = 0; i < 200; ++i) {
    std::size_t files = 0;
    if (fs::exists(out))
      for (const auto& e : fs::recursive_directory_iterator(out)) files += e.path().extension() == ".jpg";
    if (files > 40) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(25));
  }
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);
  const auto resumed =
      run_pvcap(fmt::format("export {} --layout pressurevision --out {}", rec.session.string(), out.string()));
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  EXPECT_EQ(resumed.output.find(", 0 found from an earlier run"), std::string::npos)
      << "the killed run's frames are kept: " << resumed.output;
  const json back = read_back(out, rec.session);
  ASSERT_TRUE(back.is_object()) << "every frame readable after the resume";
  const json whole = read_back(rec.work / "pv", rec.session);
  if (whole.is_object()) {
    EXPECT_EQ(back["sequences"].size(), whole["sequences"].size());
  }

  // Mistakes: one message naming what and where, exit 1.
  const auto no_take = run_pvcap(fmt::format("export {} --out {} --take nonesuch", rec.session.string(), out.string()));
  EXPECT_EQ(no_take.exit_code, 1);
  EXPECT_NE(no_take.output.find("no take named 'nonesuch'"), std::string::npos) << no_take.output;
  const auto no_camera = run_pvcap(fmt::format("export {} --out {} --cameras 7", rec.session.string(), out.string()));
  EXPECT_EQ(no_camera.exit_code, 1);
  EXPECT_NE(no_camera.output.find("there is no camera 7"), std::string::npos) << no_camera.output;

  // A crafted store (its pseudonym a path) and a crafted output folder (its participant mapping
  // pointing out): refused with the file named, and nothing is written outside --out.
  const fs::path crafted = rec.work / "crafted" / rec.session.filename();
  fs::create_directories(crafted);
  // The videos linked (they are not changed), the index and its WAL copied (they are).
  for (const auto& e : fs::directory_iterator(rec.session)) {
    if (!e.is_regular_file()) continue;
    if (e.path().filename().string().rfind("session.db", 0) == 0)
      fs::copy_file(e.path(), crafted / e.path().filename());
    else
      fs::create_hard_link(e.path(), crafted / e.path().filename());
  }
  {
    pvcap::sqlite::Database db(crafted / "session.db", pvcap::sqlite::Database::Mode::ReadWrite);
    db.exec("UPDATE participant SET pseudonym = '../../escaped'");
  }
  const fs::path jail = rec.work / "jail", jailed_out = jail / "a" / "out";
  const auto by_store = run_pvcap(fmt::format("export {} --out {}", crafted.string(), jailed_out.string()));
  EXPECT_EQ(by_store.exit_code, 1) << by_store.output;
  EXPECT_NE(by_store.output.find("pseudonym '../../escaped' cannot be a folder name"), std::string::npos)
      << by_store.output;
  fs::create_directories(jailed_out);
  std::ofstream(jailed_out / "participants.json") << R"({"P017": "../../escaped"})";
  const auto by_mapping = run_pvcap(fmt::format("export {} --out {}", rec.session.string(), jailed_out.string()));
  EXPECT_EQ(by_mapping.exit_code, 1) << by_mapping.output;
  EXPECT_NE(by_mapping.output.find("participants.json: the folder '../../escaped'"), std::string::npos)
      << by_mapping.output;
  for (const auto& e : fs::recursive_directory_iterator(jail)) {
    if (jailed_out.string().rfind(e.path().string(), 0) == 0) continue;  // one of --out's own parents
    EXPECT_EQ(e.path().string().rfind(jailed_out.string(), 0), 0u) << "written outside --out: " << e.path();
  }
}

// The paper's crop: frames of 480 x 384 around the pad, and the loaders' own geometry (their pad
// through the exported pose and intrinsics, as spec 2.1 computes it) still lands on the grid's
// corners, now in the cropped frame.
TEST(Export, ThePapersCropKeepsTheLoadersGeometryOnTheCroppedFrames) {
  const Recorded& rec = recorded();
  ASSERT_FALSE(rec.session.empty());
  const fs::path out = rec.work / "crop";
  const std::string take = "press_index_finger_low_2x_left";
  const auto run =
      run_pvcap(fmt::format("export {} --out {} --take {} --crop-paper", rec.session.string(), out.string(), take));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const fs::path dir = out / "0001_P017" / take;
  const json meta = json::parse(read_all(dir / "metadata.json"));
  auto truth = pvcap::sim::read_rig_truth(rec.session / "sim-truth");
  ASSERT_TRUE(truth);
  auto reader = pvcap::SessionReader::open(rec.session);
  ASSERT_TRUE(reader);
  const std::size_t first_sample = meta["pvcap"]["samples"][0];
  for (std::size_t k = 0; k < 4; ++k) {
    SCOPED_TRACE(k);
    const cv::Mat jpg = pvcap::testing::read_picture(dir / fmt::format("camera_{}", k) / "00000.jpg");
    ASSERT_EQ(jpg.size(), cv::Size(480, 384));
    const json box = meta["pvcap"]["cameras"][k]["crop_box"];
    const cv::Rect r(box[0], box[1], box[2], box[3]);
    // The frame is the recorded one, cropped and resized (JPEG's error aside).
    auto image = reader.value()->image(first_sample, k);
    ASSERT_TRUE(image);
    cv::Mat expected;
    cv::resize(image.value()(r), expected, {480, 384}, 0, 0, cv::INTER_LINEAR);
    EXPECT_LT(cv::norm(jpg, expected, cv::NORM_L1) / double(jpg.total() * 3), 3.0);
    // The loaders' corners, computed from the metadata as they compute them.
    const json& c = meta["camera_calibrations"][std::to_string(k)];
    cv::Matx33d R;
    cv::Vec3d t;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) R(i, j) = c["ModelViewMatrix"][i][j];
      t[i] = c["ModelViewMatrix"][i][3].get<double>() / 1000;
    }
    cv::Vec3d rvec;
    cv::Rodrigues(R, rvec);
    const cv::Matx33d K(c["fx"], 0, c["cx"], 0, c["fy"], c["cy"], 0, 0, 1);
    std::vector<cv::Point3d> world{
        {0.149, -0.001, 0.251}, {0.014, -0.001, 0.251}, {0.014, -0.001, 0.016}, {0.149, -0.001, 0.016}};
    std::vector<cv::Point2d> corners;
    cv::projectPoints(world, rvec, t, cv::Mat(K), cv::Mat(), corners);
    const auto& tc = truth.value().cameras[k].pad_corners_px;  // (0,0), (185,0), (185,105), (0,105)
    const cv::Point2d expect[4] = {tc[1], tc[2], tc[3], tc[0]};
    const double sx = 480.0 / r.width, sy = 384.0 / r.height;
    for (int i = 0; i < 4; ++i) {
      const cv::Point2d in_crop((expect[i].x - r.x + 0.5) * sx - 0.5, (expect[i].y - r.y + 0.5) * sy - 0.5);
      EXPECT_LT(cv::norm(corners[std::size_t(i)] - in_crop), 3.0 * std::max(sx, sy)) << i;
    }
  }
}
