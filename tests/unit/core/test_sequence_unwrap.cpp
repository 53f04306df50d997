#include <gtest/gtest.h>

#include "core/sequence_unwrap.h"

using pvcap::SequenceUnwrapper;

TEST(SequenceUnwrap, ContiguousIdsReportNothingMissing) {
  SequenceUnwrapper u(16, true);
  EXPECT_EQ(u.next(10).sequence, 10u);
  const auto s = u.next(11);
  EXPECT_EQ(s.sequence, 11u);
  EXPECT_EQ(s.missing, 0u);
  EXPECT_FALSE(s.out_of_order);
}

TEST(SequenceUnwrap, GapIsCountedByTheDevicesNumbering) {
  SequenceUnwrapper u(16, true);
  (void)u.next(100);
  const auto s = u.next(104);
  EXPECT_EQ(s.sequence, 104u);
  EXPECT_EQ(s.missing, 3u);
}

TEST(SequenceUnwrap, GigEWrapSkipsZero) {
  SequenceUnwrapper u(16, true);
  (void)u.next(65534);
  EXPECT_EQ(u.next(65535).missing, 0u);
  const auto s = u.next(1);  // 65535 -> 1: contiguous on GigE Vision 1.x
  EXPECT_EQ(s.sequence, 65536u);
  EXPECT_EQ(s.missing, 0u);
  EXPECT_EQ(u.next(2).sequence, 65537u);
}

TEST(SequenceUnwrap, GapAcrossTheWrapCountsOnlyRealIds) {
  SequenceUnwrapper u(16, true);
  (void)u.next(65534);
  const auto s = u.next(2);  // lost 65535 and 1
  EXPECT_EQ(s.missing, 2u);
  EXPECT_EQ(s.sequence, 65534u + 3u);
}

TEST(SequenceUnwrap, EightBitCounterWithZeroWrapsEvery256) {
  SequenceUnwrapper u(8, false);
  (void)u.next(255);
  const auto s = u.next(0);
  EXPECT_EQ(s.sequence, 256u);
  EXPECT_EQ(s.missing, 0u);
}

TEST(SequenceUnwrap, ManyWrapsKeepCounting) {
  SequenceUnwrapper u(16, true);
  std::uint64_t raw = 60000, last = 0;
  for (int i = 0; i < 300000; ++i) {
    last = u.next(raw).sequence;
    raw = raw == 65535 ? 1 : raw + 1;
  }
  EXPECT_EQ(last, 60000u + 299999u);
}

TEST(SequenceUnwrap, RepeatedOrOlderIdIsFlaggedAndDoesNotMoveTheSequence) {
  SequenceUnwrapper u(16, true);
  (void)u.next(500);
  EXPECT_TRUE(u.next(500).out_of_order);
  const auto late = u.next(499);
  EXPECT_TRUE(late.out_of_order);
  EXPECT_EQ(late.sequence, 499u);
  const auto s = u.next(501);
  EXPECT_FALSE(s.out_of_order);
  EXPECT_EQ(s.sequence, 501u);
  EXPECT_EQ(s.missing, 0u);
}

TEST(SequenceUnwrap, LateFrameAcrossTheWrapGetsItsOwnSequence) {
  SequenceUnwrapper u(16, true);
  (void)u.next(65534);
  (void)u.next(1);  // 65535 missing so far; sequence 65536
  const auto late = u.next(65535);
  EXPECT_TRUE(late.out_of_order);
  EXPECT_EQ(late.sequence, 65535u);
}
