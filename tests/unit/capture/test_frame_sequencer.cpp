// The camera driver's numbering: frame ids unwrapped per connection, gaps held open for late
// frames, losses reported with their true reason, buffers that are not their frame named.
#include <gtest/gtest.h>

#include "capture/frame_sequencer.h"

namespace pvcap {
namespace {

constexpr std::int64_t kMs = 1'000'000;

CameraFrame frame(std::uint64_t id, std::int64_t at_ms, FrameStatus status = FrameStatus::Good) {
  CameraFrame f;
  f.frame_id = id;
  f.host_ts = HostNs{at_ms * kMs};
  f.status = status;
  return f;
}

struct Sequenced {
  FrameSequencer seq{7, 1000 * kMs};
  std::vector<FrameLoss> losses;
  CameraFrame add(std::uint64_t id, std::int64_t at_ms, FrameStatus status = FrameStatus::Good) {
    CameraFrame f = frame(id, at_ms, status);
    seq.identify(f);
    return f;
  }
  void settle(std::int64_t at_ms, std::uint64_t underruns = 0, bool all = false) {
    seq.settle(HostNs{at_ms * kMs}, underruns, losses, all);
  }
};

TEST(FrameSequencer, UnwrapsIdsPastTheWrapWhereZeroDoesNotExist) {
  Sequenced s;
  EXPECT_EQ(s.add(65534, 0).sequence, 65534u);
  const auto last = s.add(65535, 16);
  const auto wrapped = s.add(1, 33);
  EXPECT_EQ(last.sequence, 65535u);
  EXPECT_EQ(wrapped.sequence, 65536u);
  EXPECT_EQ(wrapped.lost_before, 0u);
  EXPECT_EQ(wrapped.identity, FrameIdentity::Own);
  s.settle(5000, 0, true);
  EXPECT_TRUE(s.losses.empty());
}

TEST(FrameSequencer, AGapIsReportedAfterTheGraceAsNotReceived) {
  Sequenced s;
  s.add(10, 0);
  const auto after = s.add(14, 66);
  EXPECT_EQ(after.lost_before, 3u);
  s.settle(500);
  EXPECT_TRUE(s.losses.empty()) << "reported before the grace ended";
  EXPECT_FALSE(s.seq.has_due(HostNs{500 * kMs}));
  EXPECT_TRUE(s.seq.has_due(HostNs{1066 * kMs}));
  s.settle(1066);
  ASSERT_EQ(s.losses.size(), 1u);
  EXPECT_EQ(s.losses[0].connection, 7u);
  EXPECT_EQ(s.losses[0].first, 11u);
  EXPECT_EQ(s.losses[0].count, 3u);
  EXPECT_STREQ(s.losses[0].reason, "not_received");
  EXPECT_EQ(s.losses[0].noticed.ns, 66 * kMs);
}

TEST(FrameSequencer, ALateIncompleteFrameClosesItsPartOfTheGap) {
  Sequenced s;
  s.add(10, 0);
  s.add(14, 66);
  const auto late = s.add(12, 80, FrameStatus::Incomplete);
  EXPECT_EQ(late.sequence, 12u);
  EXPECT_EQ(late.identity, FrameIdentity::Own) << "a frame we were missing is the frame it says";
  s.settle(2000);
  ASSERT_EQ(s.losses.size(), 2u);
  std::uint64_t lost = 0;
  for (const auto& l : s.losses) {
    EXPECT_NE(l.first, 12u);
    lost += l.count;
  }
  EXPECT_EQ(lost, 2u) << "frames 11 and 13";
}

TEST(FrameSequencer, BuffersThatAreNotTheirFrameAreNamed) {
  Sequenced s;
  s.add(10, 0);
  s.add(11, 16);
  EXPECT_EQ(s.add(11, 20).identity, FrameIdentity::Duplicate);
  EXPECT_EQ(s.add(11, 40, FrameStatus::Incomplete).identity, FrameIdentity::StaleMetadata);
  const auto no_id = s.add(0, 50, FrameStatus::Incomplete);
  EXPECT_EQ(no_id.identity, FrameIdentity::NoFrameId);
  EXPECT_EQ(no_id.sequence, 0u);
  EXPECT_EQ(s.add(12, 66).lost_before, 0u) << "a buffer without identity is no frame of the sequence";
}

TEST(FrameSequencer, GapsWhileAravisHadNoBufferAreChargedToTheUnderrun) {
  Sequenced s;
  s.add(1, 0);
  s.add(11, 160);  // 9 missing
  s.settle(1200, /*underruns=*/6);
  ASSERT_EQ(s.losses.size(), 2u);
  EXPECT_STREQ(s.losses[0].reason, "buffer_underrun");
  EXPECT_EQ(s.losses[0].first, 2u);
  EXPECT_EQ(s.losses[0].count, 6u);
  EXPECT_STREQ(s.losses[1].reason, "not_received");
  EXPECT_EQ(s.losses[1].first, 8u);
  EXPECT_EQ(s.losses[1].count, 3u);
  // The counter does not grow again: a later gap is not charged to the old underruns.
  s.add(14, 1300);
  s.settle(2400, 6);
  ASSERT_EQ(s.losses.size(), 3u);
  EXPECT_STREQ(s.losses[2].reason, "not_received");
  EXPECT_EQ(s.losses[2].count, 2u);
}

TEST(FrameSequencer, EverythingOpenIsReportedAtTheEnd) {
  Sequenced s;
  s.add(1, 0);
  s.add(5, 60);
  s.add(9, 70);
  s.settle(80, 0, /*all=*/true);  // both gaps, well inside their grace
  ASSERT_EQ(s.losses.size(), 2u);
  std::uint64_t total = 0;
  for (const auto& l : s.losses) total += l.count;
  EXPECT_EQ(total, 6u);
}

}  // namespace
}  // namespace pvcap
