#include <gtest/gtest.h>

#include <vector>

#include "ccir_mapping/core/preprocess/ordered_wait_queue.h"

namespace ccir_mapping::core::preprocess {
namespace {

// Items are stamps; an item is ready once "odometry" reached its stamp.
struct Harness {
  OrderedWaitQueue<int> queue{4};
  int odometry = 0;
  std::vector<int> released, dropped;

  void drain(const std::vector<int>& never_ready = {}) {
    queue.drain(
        [&](int stamp) {
          for (int n : never_ready) {
            if (n == stamp) return false;
          }
          return stamp <= odometry;
        },
        [&](int stamp) { released.push_back(stamp); },
        [&](int stamp) { dropped.push_back(stamp); });
  }
};

TEST(OrderedWaitQueue, ItemsWaitUntilReadyAndLeaveInOrder) {
  Harness h;
  h.queue.push(1);
  h.queue.push(2);
  h.queue.push(3);
  h.drain();
  EXPECT_TRUE(h.released.empty());
  h.odometry = 2;
  h.drain();
  EXPECT_EQ(h.released, (std::vector<int>{1, 2}));
  EXPECT_EQ(h.queue.size(), 1u);
  h.odometry = 5;
  h.drain();
  EXPECT_EQ(h.released, (std::vector<int>{1, 2, 3}));
  EXPECT_TRUE(h.dropped.empty());
  EXPECT_TRUE(h.queue.empty());
}

TEST(OrderedWaitQueue, AnItemOvertakenByALaterReadyOneIsDropped) {
  Harness h;
  h.queue.push(1);  // e.g. a scan in a frame tf never knows
  h.queue.push(2);
  h.queue.push(3);
  h.odometry = 2;
  h.drain({1});
  EXPECT_EQ(h.dropped, (std::vector<int>{1}));
  EXPECT_EQ(h.released, (std::vector<int>{2}));
  EXPECT_EQ(h.queue.size(), 1u);  // 3 still waits
}

TEST(OrderedWaitQueue, AFullQueuePushesOutTheOldest) {
  Harness h;
  for (int i = 1; i <= 4; ++i) EXPECT_FALSE(h.queue.push(i).has_value());
  const auto out = h.queue.push(5);
  ASSERT_TRUE(out.has_value());
  EXPECT_EQ(*out, 1);
  EXPECT_EQ(h.queue.size(), 4u);
  h.odometry = 10;
  h.drain();
  EXPECT_EQ(h.released, (std::vector<int>{2, 3, 4, 5}));
}

}  // namespace
}  // namespace ccir_mapping::core::preprocess
