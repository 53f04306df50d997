// The one percentile rule the report, eval-sync and the benches share: rank round(q * (n - 1)).
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>

#include "core/statistics.h"

using pvcap::percentile;

TEST(Statistics, APercentileIsTheValueAtRankQTimesNMinusOneRounded) {
  std::vector<double> hundred(100);
  std::iota(hundred.begin(), hundred.end(), 1.0);  // 1..100, given in any order
  std::reverse(hundred.begin(), hundred.end());
  EXPECT_EQ(percentile(hundred, 0.0), 1.0);
  EXPECT_EQ(percentile(hundred, 1.0), 100.0);
  EXPECT_EQ(percentile(hundred, 0.5), 51.0);   // rank round(49.5) = 50 (0-based): half up
  EXPECT_EQ(percentile(hundred, 0.99), 99.0);  // rank round(98.01) = 98
  EXPECT_EQ(percentile({3.0, 1.0, 2.0}, 0.5), 2.0) << "the median of an odd count";
  EXPECT_EQ(percentile({}, 0.99), 0.0);
  EXPECT_EQ(percentile({7.0}, 0.99), 7.0);
  EXPECT_EQ(percentile({1.0, 2.0}, 2.0), 2.0) << "q is held to [0, 1]";
}
