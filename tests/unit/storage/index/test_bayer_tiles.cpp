// The raw store's tiles (storage/video/bayer_tiles.h): a region of a frame decodes only the tiles
// under it, bit-exact, and a tiled frame read whole is the same stored picture (and checksum) as an
// untiled one.
#include <gtest/gtest.h>

#include <filesystem>

#include "sim/scene.h"
#include "storage/index/video_repair.h"
#include "storage/video/bayer_tiles.h"
#include "storage/video/frame_checksum.h"
#include "storage/video/video_reader.h"
#include "storage/video/video_writer.h"
#include "tests/unit/temp_dir.h"

namespace fs = std::filesystem;
using namespace pvcap;

namespace {
constexpr int kWidth = 320, kHeight = 180;

std::vector<cv::Mat> noisy_mosaics(int n, int depth, std::uint64_t seed) {
  cv::RNG rng(seed);
  const cv::Mat scene = sim::to_sensor_format(sim::render_default_scene_bgr(0, {kWidth, kHeight}), "BayerRG8");
  std::vector<cv::Mat> out;
  for (int i = 0; i < n; ++i) {
    cv::Mat m = scene.clone(), noise(m.size(), CV_8SC1);
    sim::draw_fingertip(m, "BayerRG8", {100.0 + 20 * i, 90.0}, 15);
    rng.fill(noise, cv::RNG::NORMAL, 0, 2);
    cv::add(m, noise, m, cv::noArray(), CV_8U);
    if (depth > 8) {
      cv::Mat deep;
      m.convertTo(deep, CV_16U, 16);
      cv::Mat low(m.size(), CV_16UC1);
      rng.fill(low, cv::RNG::UNIFORM, 0, 16);
      deep += low;
      m = deep;
    }
    out.push_back(m);
  }
  return out;
}

VideoSettings tiled(const std::string& codec, int depth, int cols, int rows) {
  VideoSettings s;
  s.bayer_format = depth > 8 ? "BayerRG12" : "BayerRG8";
  s.bit_depth = depth;
  s.raw_codec = codec;
  s.width = kWidth;
  s.height = kHeight;
  s.tile_cols = cols;
  s.tile_rows = rows;
  s.gop_frames = 4;
  return s;
}

std::int64_t pts_ms(int i) { return ((i + 1) * 66'667 + 500) / 1000; }
}  // namespace

TEST(TileGrid, CutsIntoWholeEvenTilesOrFewer) {
  const TileGrid g = tile_grid({1920, 1080}, 8, 6);
  EXPECT_EQ(g.tag(), "8x6");
  EXPECT_EQ(g.tile_size(), cv::Size(240, 180));
  EXPECT_EQ(g.mosaic_rect(9), cv::Rect(240, 180, 240, 180));
  // 1080 rows do not cut into 7 even parts, nor 1920 columns into 7: the next fewer that do.
  EXPECT_EQ(tile_grid({1920, 1080}, 7, 7).tag(), "6x6");
  EXPECT_EQ(tile_grid({322, 180}, 4, 4).tag(), "1x3");  // 322 = 2 x 161: no even cut at all
  // The tiles a box touches, in row-major order; a box past the mosaic touches what is inside.
  EXPECT_EQ(g.covering({230, 170, 20, 20}), (std::vector<int>{0, 1, 8, 9}));
  EXPECT_EQ(g.covering({1900, 1070, 100, 100}), (std::vector<int>{47}));
  EXPECT_TRUE(g.covering({2000, 0, 10, 10}).empty());

  ASSERT_TRUE(parse_tile_grid("8x6", {1920, 1080}));
  for (const char* bad : {"", "8", "8x", "x6", "8x6x", "0x6", "7x6", "8x-6", "+8x6", "65x1"}) {
    const auto p = parse_tile_grid(bad, {1920, 1080});
    ASSERT_FALSE(p) << bad;
    EXPECT_NE(p.error().message.find("whole, even tiles"), std::string::npos) << p.error().message;
  }
}

TEST(TileGrid, TilesCopiedOutOfThePlanesAndBackAreThePlanes) {
  cv::Mat planes(2 * kHeight, kWidth / 2, CV_8UC1);
  cv::randu(planes, 0, 256);
  const TileGrid g = tile_grid({kWidth, kHeight}, 4, 3);
  cv::Mat back(planes.size(), planes.type(), cv::Scalar(0));
  for (int t = 0; t < g.count(); ++t) {
    cv::Mat tile;
    copy_tile_from_planes(planes, g, t, tile);
    EXPECT_EQ(tile.size(), bayer_planes_size(g.tile_size()));
    copy_tile_to_planes(tile, g, t, back);
  }
  EXPECT_EQ(cv::norm(planes, back, cv::NORM_INF), 0.0);
}

TEST(TiledVideo, ARegionDecodesOnlyItsTilesBitExactAndTheWholeFrameKeepsItsChecksum) {
  struct Case {
    std::string codec;
    int depth;
    std::string preset = "ultrafast";  // libx264's: veryfast looks ahead, so its tiles leave late
  };
  for (const Case& c : {Case{"ffvhuff", 8}, Case{"ffvhuff", 12}, Case{"ffv1", 8}, Case{"libx264", 8},
                        Case{"libx264", 8, "veryfast"}}) {
    SCOPED_TRACE(c.codec + " " + std::to_string(c.depth) + " " + c.preset);
    const pvcap::testing::TempDir dir{pvcap::testing::fresh_temp_dir("tiles", "video")};
    const auto mosaics = noisy_mosaics(6, c.depth, 11);
    VideoSettings settings = tiled(c.codec, c.depth, 4, 3);
    settings.preset = c.preset;
    auto w = VideoWriter::open(dir.path / "v.mkv", settings);
    ASSERT_TRUE(w) << w.error().message;
    EXPECT_EQ(w.value()->tile_grid().tag(), "4x3");
    for (int i = 0; i < 6; ++i) {
      ASSERT_TRUE(w.value()->write(mosaics[std::size_t(i)], (i + 1) * 66'667));
      // The planes the view video is made of are the whole mosaic's, tiled or not.
      cv::Mat expected;
      pack_bayer_planes(mosaics[std::size_t(i)], expected, w.value()->plane_order());
      EXPECT_EQ(cv::norm(w.value()->stored_planes(), expected, cv::NORM_INF), 0.0);
    }
    ASSERT_TRUE(w.value()->close().ok());

    auto r = VideoReader::open(dir.path / "v.mkv");
    ASSERT_TRUE(r) << r.error().message;
    VideoReader& v = *r.value();
    EXPECT_EQ(v.tiles(), 12);
    EXPECT_EQ(v.width(), kWidth);
    EXPECT_EQ(v.height(), kHeight);
    EXPECT_EQ(v.bit_depth(), c.depth);
    const bool intra = c.codec == "ffvhuff";
    EXPECT_EQ(v.tile_decoders(), intra ? 1 : 12) << "HuffYUV's tiles share one decoder; a GOP's keep their own";
    // Regions, backwards and across tile edges: exactly the mosaic's pixels; an intra-only codec
    // decodes the tiles under the region alone (80x60 tiles: this box touches tiles 5, 6, 9, 10).
    for (int i = 5; i >= 0; --i) {
      const cv::Rect box(78, 58, 60, 50);
      cv::Mat region;
      const auto tiles_before = v.tiles_decoded();
      auto found = v.read_raw_region_at(pts_ms(i), box, region);
      ASSERT_TRUE(found && found.value()) << i << " " << (found ? "" : found.error().message);
      EXPECT_EQ(cv::norm(region, mosaics[std::size_t(i)](box), cv::NORM_INF), 0.0) << "frame " << i;
      if (intra) {
        EXPECT_EQ(v.tiles_decoded() - tiles_before, 4u) << "frame " << i;
      }
      // A region of an intra-only video has no checksum; a GOP's frames decode whole, checksum and all.
      EXPECT_EQ(v.decoded_picture_crc(), intra ? std::nullopt
                                               : std::optional(stored_mosaic_crc(mosaics[std::size_t(i)], v.plane_order())));
    }
    // Whole frames: the stored picture is the untiled one, so the capture checksum holds.
    for (int i = 0; i < 6; ++i) {
      cv::Mat mosaic;
      ASSERT_TRUE(v.read_raw_at(pts_ms(i), mosaic).value()) << i;
      EXPECT_EQ(cv::norm(mosaic, mosaics[std::size_t(i)], cv::NORM_INF), 0.0) << "frame " << i;
      EXPECT_EQ(v.decoded_picture_crc(), stored_mosaic_crc(mosaics[std::size_t(i)], v.plane_order())) << i;
    }
    // A region not of whole Bayer cells, or outside the image, is refused with what is wrong.
    cv::Mat region;
    auto odd = v.read_raw_region_at(pts_ms(0), {1, 0, 10, 10}, region);
    ASSERT_FALSE(odd);
    EXPECT_NE(odd.error().message.find("whole Bayer cells"), std::string::npos) << odd.error().message;
    EXPECT_FALSE(v.read_raw_region_at(pts_ms(0), {310, 0, 20, 10}, region));

    // In file order, as verify and repair read: every frame's stored picture and its checksum.
    auto seq = VideoReader::open(dir.path / "v.mkv");
    ASSERT_TRUE(seq);
    cv::Mat picture;
    std::int64_t at = 0;
    bool key = false;
    for (int i = 0; i < 6; ++i) {
      ASSERT_TRUE(seq.value()->next_stored(picture, at, key).value()) << i;
      EXPECT_EQ(at, pts_ms(i));
      EXPECT_EQ(key, intra || i % 4 == 0) << i;
      EXPECT_EQ(picture_crc(picture), stored_mosaic_crc(mosaics[std::size_t(i)], seq.value()->plane_order())) << i;
    }
    EXPECT_FALSE(seq.value()->next_stored(picture, at, key).value());
  }
}

TEST(TiledVideo, AViewersReaderDecodesThreePlanesOfEachTile) {
  const pvcap::testing::TempDir dir{pvcap::testing::fresh_temp_dir("tiles", "views")};
  const auto mosaics = noisy_mosaics(3, 8, 5);
  for (const char* name : {"tiled.mkv", "whole.mkv"}) {
    const bool tiles = name == std::string("tiled.mkv");
    auto w = VideoWriter::open(dir.path / name, tiled("ffvhuff", 8, tiles ? 4 : 1, tiles ? 3 : 1));
    ASSERT_TRUE(w);
    for (int i = 0; i < 3; ++i) ASSERT_TRUE(w.value()->write(mosaics[std::size_t(i)], (i + 1) * 66'667));
    ASSERT_TRUE(w.value()->close().ok());
  }
  // The tiled video's viewer sees what the untiled one's sees (three planes: the first green alone).
  VideoReader::Options views;
  views.half_size_colour_only = true;
  auto tiled_viewer = VideoReader::open(dir.path / "tiled.mkv", views);
  auto viewer = VideoReader::open(dir.path / "whole.mkv", views);
  ASSERT_TRUE(tiled_viewer && viewer);
  EXPECT_EQ(tiled_viewer.value()->tiles(), 12);
  EXPECT_TRUE(tiled_viewer.value()->decodes_three_planes());
  EXPECT_TRUE(viewer.value()->decodes_three_planes());
  tiled_viewer.value()->set_demosaic(Demosaic::HalfSize);
  viewer.value()->set_demosaic(Demosaic::HalfSize);
  for (int i = 0; i < 3; ++i) {
    cv::Mat seen, expected;
    ASSERT_TRUE(tiled_viewer.value()->read_at(pts_ms(i), seen).value());
    ASSERT_TRUE(viewer.value()->read_at(pts_ms(i), expected).value());
    ASSERT_EQ(seen.size(), cv::Size(kWidth / 2, kHeight / 2));
    EXPECT_EQ(cv::norm(seen, expected, cv::NORM_INF), 0.0) << i;
  }
  cv::Mat mosaic;
  EXPECT_FALSE(tiled_viewer.value()->read_raw_at(pts_ms(0), mosaic)) << "a three-plane reader has no mosaic";
}

TEST(TiledVideo, AFrameCutBetweenItsTilesIsNotAFrame) {
  const pvcap::testing::TempDir dir{pvcap::testing::fresh_temp_dir("tiles", "cut")};
  const auto mosaics = noisy_mosaics(4, 8, 3);
  const fs::path file = dir.path / "v.mkv";
  {
    auto w = VideoWriter::open(file, tiled("ffvhuff", 8, 4, 3));
    ASSERT_TRUE(w);
    for (int i = 0; i < 4; ++i) ASSERT_TRUE(w.value()->write(mosaics[std::size_t(i)], (i + 1) * 66'667));
    // No close: a crash. Every frame ended its cluster, so the four are in the file.
    const auto size = fs::file_size(file);
    fs::copy_file(file, dir.path / "whole.mkv");
    // Cut the copy inside the last frame's tiles (they are its last ~1/12 of bytes each).
    fs::resize_file(dir.path / "whole.mkv", size - 1500);
  }
  auto r = VideoReader::open(dir.path / "whole.mkv");
  ASSERT_TRUE(r) << r.error().message;
  int frames = 0;
  std::int64_t at = 0;
  bool key = false;
  while (r.value()->next_packet(at, key).value()) ++frames;
  EXPECT_EQ(frames, 3) << "the last frame lost its last tiles: it is not counted";
  auto again = VideoReader::open(dir.path / "whole.mkv");
  cv::Mat picture;
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(again.value()->next_stored(picture, at, key).value()) << i;
    EXPECT_EQ(picture_crc(picture), stored_mosaic_crc(mosaics[std::size_t(i)], again.value()->plane_order()));
  }
  EXPECT_FALSE(again.value()->next_stored(picture, at, key).value());

  // Recovery keeps the whole frames, every tile of them, and nothing of the cut one.
  ASSERT_TRUE(remux_prefix(dir.path / "whole.mkv", dir.path / "kept.mkv", 3).ok());
  auto kept = VideoReader::open(dir.path / "kept.mkv");
  ASSERT_TRUE(kept) << kept.error().message;
  EXPECT_EQ(kept.value()->tiles(), 12);
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(kept.value()->next_stored(picture, at, key).value()) << i;
    EXPECT_EQ(at, pts_ms(i));
    EXPECT_EQ(picture_crc(picture), stored_mosaic_crc(mosaics[std::size_t(i)], kept.value()->plane_order()));
  }
  EXPECT_FALSE(kept.value()->next_stored(picture, at, key).value());
  ASSERT_TRUE(remux_prefix(dir.path / "whole.mkv", dir.path / "two.mkv", 2).ok());
  auto two = VideoReader::open(dir.path / "two.mkv");
  ASSERT_TRUE(two);
  int n = 0;
  while (two.value()->next_packet(at, key).value()) ++n;
  EXPECT_EQ(n, 2);
}
