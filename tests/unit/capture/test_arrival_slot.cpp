// A stream buffer's arrival stamps: each take of the buffer paired with its own fill's stamp, whether
// Aravis called back before or after queueing it, and a stamp that comes too late marked as such.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "capture/arrival_slot.h"

namespace pvcap {
namespace {

using namespace std::chrono_literals;

TEST(ArrivalSlot, ATakeAfterItsStampGetsThatStamp) {
  ArrivalSlot slot;
  const std::atomic<bool> accepting{true};
  slot.stamp(HostNs{1000}, true);
  const auto a = slot.take(2ms, accepting);
  EXPECT_EQ(a.at.ns, 1000);
  EXPECT_TRUE(a.accepted);
  EXPECT_FALSE(a.late);
  slot.stamp(HostNs{2000}, false);  // the next fill, finished after a quiesce
  const auto b = slot.take(2ms, accepting);
  EXPECT_EQ(b.at.ns, 2000);
  EXPECT_FALSE(b.accepted) << "the fill's own acceptance, not the stream's now";
  EXPECT_FALSE(b.late);
}

TEST(ArrivalSlot, ATakeBeforeItsStampWaitsForIt) {
  // Aravis 0.8.26 queues a GigE buffer, then calls back: the consumer may take it first.
  ArrivalSlot slot;
  const std::atomic<bool> accepting{true};
  slot.stamp(HostNs{1000}, true);
  ASSERT_EQ(slot.take(2ms, accepting).at.ns, 1000);
  std::thread stream_thread([&] {
    std::this_thread::sleep_for(5ms);
    slot.stamp(HostNs{2000}, true);
  });
  const auto a = slot.take(10s, accepting);
  stream_thread.join();
  EXPECT_EQ(a.at.ns, 2000) << "the previous fill's stamp, read before this fill's came";
  EXPECT_FALSE(a.late);
}

TEST(ArrivalSlot, AStampThatDoesNotComeInTimeIsTheTakesMomentAndStaysWithThatTake) {
  ArrivalSlot slot;
  std::atomic<bool> accepting{true};
  const std::int64_t before = host_now().ns;
  const auto a = slot.take(2ms, accepting);
  EXPECT_TRUE(a.late);
  EXPECT_GE(a.at.ns, before + 2'000'000) << "given up before the wait ran out";
  EXPECT_TRUE(a.accepted) << "a late take says whether frames are taken as it gives up";
  accepting = false;
  EXPECT_FALSE(slot.take(1ms, accepting).accepted);
  // The two late stamps come, then the third fill's: the third take gets the third stamp.
  slot.stamp(HostNs{1000}, true);
  slot.stamp(HostNs{2000}, true);
  slot.stamp(HostNs{3000}, true);
  const auto c = slot.take(2ms, accepting);
  EXPECT_EQ(c.at.ns, 3000);
  EXPECT_FALSE(c.late);
}

}  // namespace
}  // namespace pvcap
