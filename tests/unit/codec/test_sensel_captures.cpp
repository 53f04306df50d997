// The real Sensel Morph captures in ../shared/data/sensel-captures are the codec's test vectors.
#include <gtest/gtest.h>

#include <filesystem>

#include "codec/sensel_capture_file.h"
#include "codec/sensel_frame.h"

namespace fs = std::filesystem;
using namespace pvcap::sensel;

namespace {
std::vector<fs::path> capture_files() {
  std::vector<fs::path> out;
  const fs::path dir = fs::path(PVCAP_SOURCE_DIR) / ".." / "shared" / "data" / "sensel-captures";
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".json" || e.path().extension() == ".jsonl") out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}
}  // namespace

TEST(SenselCaptures, EveryFrameDecodesWithEveryByteUsedAndReencodesToTheSameBytes) {
  const auto files = capture_files();
  ASSERT_EQ(files.size(), 4u) << "expected the 4 stored captures";
  std::size_t frames = 0, with_pressure = 0, touched = 0;
  for (const auto& path : files) {
    auto file = load_capture_file(path);
    ASSERT_TRUE(file) << file.error().message;
    auto grid = grid_from_metadata(file.value().metadata);
    ASSERT_TRUE(grid) << grid.error().message;
    EXPECT_EQ(grid.value(), kHighDetail) << path;
    ASSERT_FALSE(file.value().frames.empty()) << path;
    for (const auto& cf : file.value().frames) {
      SCOPED_TRACE(path.filename().string() + " frame at " + std::to_string(cf.line));
      ++frames;
      EXPECT_EQ(int(checksum(cf.payload)), cf.checksum);
      auto f = parse_frame(cf.payload, grid.value());
      ASSERT_TRUE(f) << f.error().message;
      EXPECT_EQ(encode_frame(f.value()), cf.payload);
      if (f.value().pressure) {
        ++with_pressure;
        EXPECT_EQ(f.value().pressure->counts.size(), std::size_t(93 * 53));
        for (auto c : f.value().pressure->counts)
          if (c) {
            ++touched;
            break;
          }
      }
    }
  }
  EXPECT_GT(frames, 1800u);
  EXPECT_GT(with_pressure, 1800u);
  EXPECT_GT(touched, 100u) << "the captures include presses: some frames must carry force";
}
