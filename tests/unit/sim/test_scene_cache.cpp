#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include <fmt/format.h>

#include "sim/scene.h"
#include "sim/scene_cache.h"

using namespace pvcap::sim;
namespace fs = std::filesystem;

namespace {
struct CacheDir {
  fs::path dir = fs::temp_directory_path() / fmt::format("pvcap-scene-cache-{}-{}", getpid(), rand());
  ~CacheDir() { fs::remove_all(dir); }
  std::vector<fs::path> scenes() const {
    std::vector<fs::path> out;
    if (fs::exists(dir))
      for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path());
    return out;
  }
};

bool same(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::countNonZero(a.reshape(1) != b.reshape(1)) == 0;
}
}  // namespace

TEST(SceneCache, ASceneIsRenderedOnceAndReadBackTheSameBitForBit) {
  CacheDir cache;
  int renders = 0;
  auto render = [&] {
    ++renders;
    return to_sensor_format(render_default_scene_bgr(1, {320, 180}), "BayerRG8");
  };
  const cv::Mat first = cached_scene(cache.dir, "camera 1", render);
  ASSERT_EQ(renders, 1);
  ASSERT_EQ(cache.scenes().size(), 1u) << "the render was not stored";
  const cv::Mat again = cached_scene(cache.dir, "camera 1", render);
  EXPECT_EQ(renders, 1) << "rendered again although the scene was stored";
  EXPECT_TRUE(same(first, again));
  EXPECT_TRUE(same(again, to_sensor_format(render_default_scene_bgr(1, {320, 180}), "BayerRG8")));
  // Another key is another scene.
  (void)cached_scene(cache.dir, "camera 2", render);
  EXPECT_EQ(renders, 2);
  EXPECT_EQ(cache.scenes().size(), 2u);
}

TEST(SceneCache, ADamagedOrCutFileIsRenderedAgainAndReplaced) {
  CacheDir cache;
  int renders = 0;
  const cv::Mat truth = to_sensor_format(render_default_scene_bgr(0, {160, 90}), "RGB8");
  auto render = [&] {
    ++renders;
    return truth.clone();
  };
  (void)cached_scene(cache.dir, "k", render);
  ASSERT_EQ(cache.scenes().size(), 1u);
  const fs::path file = cache.scenes().front();
  const auto size = fs::file_size(file);
  {  // a flipped bit in the pixels: only the CRC can tell
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(std::streamoff(size - 100));
    char c = 0;
    f.read(&c, 1);
    c = char(c ^ 0x10);
    f.seekp(std::streamoff(size - 100));
    f.write(&c, 1);
  }
  EXPECT_TRUE(same(cached_scene(cache.dir, "k", render), truth));
  EXPECT_EQ(renders, 2) << "a damaged scene was used";
  EXPECT_TRUE(same(cached_scene(cache.dir, "k", render), truth));
  EXPECT_EQ(renders, 2) << "the damaged file was not replaced";
  fs::resize_file(file, size / 2);
  EXPECT_TRUE(same(cached_scene(cache.dir, "k", render), truth));
  EXPECT_EQ(renders, 3) << "a cut scene was used";
}

TEST(SceneCache, KeepsTheMostRecentlyUsedScenesOnly) {
  CacheDir cache;
  auto render = [] { return cv::Mat(100, 100, CV_8UC1, cv::Scalar(7)); };
  // Room for ten and a half scenes of one file's size (its pixels, key and header).
  (void)cached_scene(cache.dir, "scene 0", render);
  ASSERT_EQ(cache.scenes().size(), 1u);
  const std::uintmax_t size = fs::file_size(cache.scenes().front());
  const std::uintmax_t budget = 10 * size + size / 2;
  for (int i = 1; i < 13; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));  // past the file system's clock tick
    (void)cached_scene(cache.dir, fmt::format("scene {}", i), render, budget);
  }
  EXPECT_EQ(cache.scenes().size(), 10u);
  int renders = 0;
  auto counted = [&] {
    ++renders;
    return render();
  };
  (void)cached_scene(cache.dir, "scene 12", counted, budget);  // the newest: kept
  EXPECT_EQ(renders, 0);
  (void)cached_scene(cache.dir, "scene 0", counted, budget);  // the oldest: removed
  EXPECT_EQ(renders, 1);
  // What a simulator killed while writing left: removed once it is an hour old, not before.
  const fs::path stale = cache.dir / "scene-0000000000000001.bin.tmp-12", fresh = cache.dir / "scene-2.bin.tmp-34";
  std::ofstream(stale) << "cut";
  std::ofstream(fresh) << "being written";
  fs::last_write_time(stale, fs::file_time_type::clock::now() - std::chrono::hours(2));
  (void)cached_scene(cache.dir, "one more", render, budget);
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::exists(fresh));
}

TEST(SceneCache, TheFolderComesFromTheEnvironmentAndCanBeTurnedOff) {
  const char* old = std::getenv("PVCAP_SIM_CACHE");
  const std::string saved = old ? old : "";
  const char* old_xdg = std::getenv("XDG_CACHE_HOME");
  const std::string saved_xdg = old_xdg ? old_xdg : "";
  setenv("PVCAP_SIM_CACHE", "/somewhere/scenes", 1);
  EXPECT_EQ(scene_cache_dir(), fs::path("/somewhere/scenes"));
  setenv("PVCAP_SIM_CACHE", "off", 1);
  EXPECT_FALSE(scene_cache_dir().has_value());
  unsetenv("PVCAP_SIM_CACHE");
  setenv("XDG_CACHE_HOME", "/xdg", 1);
  EXPECT_EQ(scene_cache_dir(), fs::path("/xdg/pvcap/sim-scenes"));
  unsetenv("XDG_CACHE_HOME");
  if (old) setenv("PVCAP_SIM_CACHE", saved.c_str(), 1);
  if (old_xdg) setenv("XDG_CACHE_HOME", saved_xdg.c_str(), 1);
  int renders = 0;
  (void)cached_scene(std::nullopt, "k", [&] {
    ++renders;
    return cv::Mat(2, 2, CV_8UC1);
  });
  (void)cached_scene(std::nullopt, "k", [&] {
    ++renders;
    return cv::Mat(2, 2, CV_8UC1);
  });
  EXPECT_EQ(renders, 2) << "without a folder every scene is rendered";
}
