#include <gtest/gtest.h>

#include <thread>

#include "core/bounded_queue.h"

using namespace std::chrono_literals;

TEST(BoundedQueue, PushFailsWhenFullInsteadOfWaiting) {
  pvcap::BoundedQueue<int> q(2);
  int a = 1, b = 2, c = 3;
  EXPECT_TRUE(q.try_push(a));
  EXPECT_TRUE(q.try_push(b));
  EXPECT_FALSE(q.try_push(c));
  EXPECT_EQ(c, 3);  // untouched: the caller still owns it
  EXPECT_EQ(q.high_water(), 2u);
}

TEST(BoundedQueue, ClosedQueueDrainsThenReportsEnd) {
  pvcap::BoundedQueue<int> q(4);
  int a = 7;
  ASSERT_TRUE(q.try_push(a));
  q.close();
  int b = 8;
  EXPECT_FALSE(q.try_push(b));
  EXPECT_FALSE(q.closed_and_empty());
  EXPECT_EQ(q.pop_for(10ms).value(), 7);
  EXPECT_TRUE(q.closed_and_empty());
  EXPECT_FALSE(q.pop_for(10ms).has_value());
}

TEST(BoundedQueue, ConsumerWakesOnPush) {
  pvcap::BoundedQueue<int> q(4);
  std::thread producer([&] {
    std::this_thread::sleep_for(20ms);
    int v = 42;
    q.try_push(v);
  });
  const auto got = q.pop_for(5s);
  producer.join();
  ASSERT_TRUE(got.has_value());
  EXPECT_EQ(*got, 42);
}

TEST(BoundedQueue, AZeroTimeoutTakesWhatIsThereInOrderAndNothingWhenEmptyOrClosed) {
  pvcap::BoundedQueue<int> q(4);
  EXPECT_FALSE(q.pop_for(0ms).has_value());  // empty: nothing, and no wait
  int a = 5, b = 6;
  ASSERT_TRUE(q.try_push(a));
  ASSERT_TRUE(q.try_push(b));
  EXPECT_EQ(q.pop_for(0ms).value(), 5);  // in order
  EXPECT_EQ(q.pop_for(0ms).value(), 6);
  EXPECT_FALSE(q.pop_for(0ms).has_value());
  q.close();
  EXPECT_FALSE(q.pop_for(0ms).has_value());
  EXPECT_TRUE(q.closed_and_empty());
}
