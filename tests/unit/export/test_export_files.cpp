// The export's file formats and geometry: the pickle is byte for byte what numpy writes, and numpy
// reads it and the .npy back; SHA-256 matches the standard's vectors; the loaders' pose fit puts
// their pad's corners nearest the measured ones.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include <opencv2/calib3d.hpp>

#include "export/dataset_export.h"
#include "export/numpy_files.h"
#include "export/pv_geometry.h"
#include "export/sha256.h"

using namespace pvcap::exporting;

namespace {
std::string python(const std::string& script, const std::string& file) {
  const std::string cmd = "/usr/bin/python3 -c \"" + script + "\" " + file;
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  char buf[4096];
  while (std::size_t n = fread(buf, 1, sizeof buf, p)) out.append(buf, n);
  pclose(p);
  return out;
}
}  // namespace

TEST(NumpyFiles, ThePickleIsWhatNumpyWritesAndNumpyReadsBoth) {
  cv::Mat small(2, 3, CV_32F);
  for (int i = 0; i < 6; ++i) small.at<float>(i) = float(i);
  // pickle.dumps(numpy.arange(6, dtype=numpy.float32).reshape(2, 3), protocol=3), numpy 1.24.
  static const char kNumpyWrote[] =
      "\x80\x03"
      "cnumpy.core.multiarray\n_reconstruct\nq\x00"
      "cnumpy\nndarray\nq\x01"
      "K\x00\x85q\x02"
      "C\x01"
      "bq\x03"
      "\x87q\x04Rq\x05(K\x01K\x02K\x03\x86q\x06"
      "cnumpy\ndtype\nq\x07X\x02\x00\x00\x00"
      "f4q\x08\x89\x88\x87q\tRq\n"
      "(K\x03X\x01\x00\x00\x00<q\x0bNNNJ\xff\xff\xff\xffJ\xff\xff\xff\xffK\x00tq\x0c"
      "b\x89"
      "C\x18"
      "\x00\x00\x00\x00\x00\x00\x80?\x00\x00\x00@\x00\x00@@\x00\x00\x80@\x00\x00\xa0@q\rtq\x0e"
      "b.";
  const std::string numpy_wrote(kNumpyWrote, sizeof kNumpyWrote - 1);
  EXPECT_EQ(numpy_pickle(small), numpy_wrote);

  cv::Mat force(105, 185, CV_32F);
  cv::randu(force, -5.0, 500.0);
  const std::string dir = ::testing::TempDir();
  std::ofstream(dir + "/force.pkl", std::ios::binary) << numpy_pickle(force);
  std::ofstream(dir + "/force.npy", std::ios::binary) << numpy_npy(force);
  const double sum = cv::sum(force)[0];
  for (const char* f : {"force.pkl", "force.npy"}) {
    const std::string loaded = python(
        std::string("import sys, pickle, numpy; f = sys.argv[1]; a = pickle.load(open(f, 'rb')) if f.endswith('pkl') "
                    "else numpy.load(f); print(a.shape, a.dtype, '%.3f' % a.astype(numpy.float64).sum(), a[104, 184])"),
        dir + "/" + f);
    char expected[128];
    std::snprintf(expected, sizeof expected, "(105, 185) float32 %.3f %g\n", sum, double(force.at<float>(104, 184)));
    EXPECT_EQ(loaded.substr(0, loaded.rfind(' ')), std::string(expected).substr(0, std::string(expected).rfind(' ')))
        << f;
    std::filesystem::remove(dir + "/" + f);
  }
}

TEST(Sha256, MatchesTheStandardsVectors) {
  EXPECT_EQ(sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(sha256_hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  EXPECT_EQ(sha256_hex(std::string(1000000, 'a')), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
  Sha256 portable(Sha256::Engine::Portable);
  portable.update("abc", 3);
  EXPECT_EQ(portable.hex(), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

// The CPU's SHA instructions and the portable code give the same digest for every length around
// the block and padding boundaries, fed whole or in uneven pieces.
TEST(Sha256, TheCpusShaInstructionsAndThePortableCodeAgree) {
  std::printf("this CPU %s SHA instructions\n", Sha256::cpu_has_sha_instructions() ? "has" : "has no");
  std::string bytes(5000, '\0');
  std::uint32_t x = 12345;
  for (char& c : bytes) c = char((x = x * 1103515245u + 12345u) >> 24);
  for (std::size_t n : {0, 1, 55, 56, 63, 64, 65, 119, 120, 127, 128, 129, 1000, 4096, 5000}) {
    Sha256 fast, portable(Sha256::Engine::Portable), pieces;
    fast.update(bytes.data(), n);
    portable.update(bytes.data(), n);
    for (std::size_t at = 0, step = 1; at < n; at += step, step = step * 3 % 97 + 1)
      pieces.update(bytes.data() + at, std::min(step, n - at));
    const std::string expected = portable.hex();
    EXPECT_EQ(fast.hex(), expected) << n << " bytes";
    EXPECT_EQ(pieces.hex(), expected) << n << " bytes in pieces";
  }
}

TEST(PvGeometry, TheLoadersCornersAreFittedToTheMeasuredOnes) {
  const cv::Matx33d K(1500, 0, 960, 0, 1500, 540, 0, 0, 1);
  // A camera that sees the loaders' own pad exactly: the fit finds the pose again, to a hair.
  const cv::Matx33d R = cv::Matx33d(1, 0, 0, 0, 0, -1, 0, 1, 0);  // world Y (the pad's normal) towards the camera
  cv::Matx44d mv = cv::Matx44d::eye();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) mv(r, c) = R(r, c);
  mv(0, 3) = -80, mv(1, 3) = -130, mv(2, 3) = 600;
  const auto exact = loader_corners(K, mv);
  PvPose p = fit_pv_pose(K, exact);
  EXPECT_LT(p.max_px, 1e-3);
  // The real grid is 231.25 x 131.25 mm, not 235 x 135: the same camera, tilted, sees the real
  // grid's corners (the loaders' world points pulled towards the pad's centre, 1.6 % along the
  // columns, 2.8 % along the rows). No rigid pose puts the loaders' corners on all of them; the fit
  // spreads the error (a few px) and reports it.
  cv::Matx33d tilt;
  cv::Rodrigues(cv::Vec3d(0.5, 0.2, 0.1), tilt);
  const cv::Matx33d Rt = tilt * R;
  std::vector<cv::Point3d> grid;
  const cv::Point3d centre(81.5, -1, 133.5);
  for (const auto& w : pv_world_corners_mm())
    grid.push_back(centre + cv::Point3d((w.x - centre.x) * 131.25 / 135, 0, (w.z - centre.z) * 231.25 / 235));
  std::vector<cv::Point2d> seen;
  cv::Vec3d rvec;
  cv::Rodrigues(Rt, rvec);
  cv::projectPoints(grid, rvec, cv::Vec3d(-80, -130, 600), cv::Mat(K), cv::Mat(), seen);
  const std::array<cv::Point2d, 4> shrunk{seen[0], seen[1], seen[2], seen[3]};
  p = fit_pv_pose(K, shrunk);
  EXPECT_GT(p.rms_px, 0.05);
  EXPECT_LT(p.max_px, 10.0);
  std::printf("loaders' pad on the real grid: %.2f px RMS, %.2f px max\n", p.rms_px, p.max_px);
  // The exact homography of PressureVision++ passes through the four corners.
  const cv::Matx33d h = corner_homography(shrunk);
  for (int i = 0; i < 4; ++i) {
    const cv::Point2d s = pv_sensor_corners()[std::size_t(i)];
    const cv::Vec3d q = h * cv::Vec3d(s.x, s.y, 1);
    EXPECT_NEAR(q[0] / q[2], shrunk[std::size_t(i)].x, 0.01);
    EXPECT_NEAR(q[1] / q[2], shrunk[std::size_t(i)].y, 0.01);
  }
}

TEST(PvGeometry, LightingCodesBecomeTheWordsTheLoadersLookFor) {
  EXPECT_EQ(light_direction_words("LCR"), "left center right");
  EXPECT_EQ(light_direction_words("L-R"), "left right");
  EXPECT_EQ(light_direction_words("unrecorded"), "unrecorded");
  EXPECT_EQ(light_direction_words(""), "unrecorded");
}
