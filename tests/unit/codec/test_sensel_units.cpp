#include <gtest/gtest.h>

#include "codec/sensel_frame.h"
#include "codec/sensel_units.h"

using namespace pvcap::sensel;

TEST(SenselUnits, WeightsMatchTheDocumentedValues) {
  const auto w0 = upsampling_weights(0.0);
  EXPECT_NEAR(w0[0], 5.0 / 32, 1e-3);
  EXPECT_NEAR(w0[1], 11.0 / 16, 1e-3);
  EXPECT_NEAR(w0[2], 5.0 / 32, 1e-3);
  EXPECT_NEAR(w0[3], 0.0, 1e-9);
  const auto wh = upsampling_weights(0.5);
  EXPECT_NEAR(wh[0], 0.0142, 2e-4);
  EXPECT_NEAR(wh[1], 0.4858, 2e-4);
  const auto wq = upsampling_weights(0.25);
  EXPECT_NEAR(wq[0], 0.0599, 2e-4);
  EXPECT_NEAR(wq[1], 0.6312, 2e-4);
  EXPECT_NEAR(wq[2], 0.3079, 2e-4);
  EXPECT_NEAR(wq[3], 0.0010, 2e-4);
  const auto w3 = upsampling_weights(0.75);  // mirror image of t = 1/4
  EXPECT_NEAR(w3[0], wq[3], 1e-6);
  EXPECT_NEAR(w3[1], wq[2], 1e-6);
}

TEST(SenselUnits, BothDetailsExpandTo185By105) {
  for (const Grid& g : {kHighDetail, kMediumDetail}) {
    EXPECT_EQ(g.out_cols(), 185);
    EXPECT_EQ(g.out_rows(), 105);
    const auto up = upsample(std::vector<std::uint16_t>(std::size_t(g.cells()), 0), g);
    EXPECT_EQ(up.size(), 185u * 105u);
  }
}

TEST(SenselUnits, InteriorFlatFieldStaysFlatAndEdgesComeOutLow) {
  const Grid g = kMediumDetail;
  const auto up = upsample(std::vector<std::uint16_t>(std::size_t(g.cells()), 800), g);
  EXPECT_NEAR(up[52 * 185 + 92], 800.0, 0.5);  // interior: weights sum to 1
  EXPECT_LT(up[52 * 185 + 0], 0.9 * 800.0);    // first column: the missing tap is not renormalised
  EXPECT_GT(up[52 * 185 + 0], 0.8 * 800.0);
}

TEST(SenselUnits, KnownPressToKilopascal) {
  // 100 g on one high-detail cell (2.5 x 2.5 mm): 0.980665 N / 6.25e-6 m^2 = 156.9 kPa.
  const double counts = 100.0 * 8;
  EXPECT_DOUBLE_EQ(counts_to_grams(counts), 100.0);
  EXPECT_NEAR(grams_to_newtons(100.0), 0.980665, 1e-9);
  EXPECT_NEAR(native_cell_kpa(counts, kHighDetail), 156.9064, 1e-3);
  // The spec's rule of thumb: at high detail 1 g per cell is about 1.57 kPa.
  EXPECT_NEAR(native_cell_kpa(8, kHighDetail), 1.569, 1e-3);
  // Medium detail cells are 4x larger: a quarter of the pressure for the same force.
  EXPECT_NEAR(native_cell_kpa(counts, kMediumDetail), 156.9064 / 4, 1e-3);
  // On the upsampled image the per-sensel pressure divides by xscale*yscale: same as the native cell.
  EXPECT_NEAR(upsampled_sensel_kpa(counts, kHighDetail), native_cell_kpa(counts, kHighDetail), 1e-9);
}

// Found by fuzz_store_damage: a grid read from a damaged store sized the decoder's buffer (a
// negative one threw std::length_error out of `pvcap verify`). A grid no Morph has is an error.
TEST(SenselCodec, AGridNoMorphHasIsRefusedBeforeDecoding) {
  const std::vector<std::uint8_t> payload = {0x01, 0x10, 0x00, 0x00, 0x00, 0x00, 0x03, 0xf5, 0x09};
  ASSERT_TRUE(pvcap::sensel::parse_frame(payload, pvcap::sensel::kMediumDetail));
  for (const pvcap::sensel::Grid g : {pvcap::sensel::Grid{-47, 27, 4, 4}, pvcap::sensel::Grid{47, 0, 4, 4},
                                      pvcap::sensel::Grid{47, 27, 0, 4}, pvcap::sensel::Grid{1 << 20, 1 << 20, 4, 4}}) {
    const auto f = pvcap::sensel::parse_frame(payload, g);
    ASSERT_FALSE(f);
    EXPECT_NE(f.error().message.find("no Morph has"), std::string::npos) << f.error().message;
  }
}
