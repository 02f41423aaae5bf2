// ScanBacklog: the live scan path's queue. Hand-worked counts of what is dropped and why, the
// lag in scan time, and a consumer thread that stop() wakes.
#include <gtest/gtest.h>

#include <algorithm>
#include <future>
#include <string>
#include <thread>
#include <vector>

#include "laser_loop_closure/core/slam/scan_backlog.hpp"

namespace {

llc::ScanBacklogOptions options(std::size_t capacity, double max_lag) {
  llc::ScanBacklogOptions o;
  o.capacity = capacity;
  o.max_lag = max_lag;
  return o;
}

TEST(ScanBacklog, AFullQueueIsThinnedEvenlyNotCutAtItsFront) {
  llc::ScanBacklog<int> backlog(options(3, 0.0));
  std::size_t dropped = 0;
  for (int k = 0; k < 5; ++k) dropped += backlog.push(k, 0.1 * k);
  // [0 1 2] + 3: 1 goes (the only one between two) -> [0 2 3]; + 4: 2 goes -> [0 3 4]. The
  // oldest stays (it follows the last scan handed out), the newest too.
  EXPECT_EQ(dropped, 2u);
  const llc::ScanBacklogCounters c = backlog.counters();
  EXPECT_EQ(c.pushed, 5u);
  EXPECT_EQ(c.dropped_full, 2u);
  EXPECT_EQ(c.dropped_behind, 0u);
  EXPECT_EQ(c.waiting, 3u);
  for (int want : {0, 3, 4}) {
    int item = -1;
    ASSERT_TRUE(backlog.pop(&item));
    EXPECT_EQ(item, want);
  }
  EXPECT_NEAR(backlog.counters().largest_lag, 0.4, 1e-12);  // scan 0 handed out when 4 was the newest
}

TEST(ScanBacklog, AConsumerThatStallsGetsScansSpreadOverTheStallNotOnlyItsEnd) {
  // 100 scans arrive while the consumer is busy (an alignment, a map rebuild) and the queue
  // holds 20: it then gets the oldest (the next after the last it had) and scans spread over
  // the stall (cut at the front: scans 80-99 only, a gap of 80 scans after the last).
  llc::ScanBacklog<int> backlog(options(20, 0.0));
  for (int k = 0; k < 100; ++k) backlog.push(k, 0.1 * k);
  std::vector<int> got;
  for (int item = -1; backlog.counters().waiting > 0 && backlog.pop(&item);) got.push_back(item);
  ASSERT_FALSE(got.empty());
  EXPECT_EQ(got.front(), 0);
  EXPECT_EQ(got.back(), 99);
  int widest = 0;
  for (std::size_t i = 1; i < got.size(); ++i) widest = std::max(widest, got[i] - got[i - 1]);
  EXPECT_LE(widest, 10) << "the widest gap between two scans handed out (5 on average)";
  EXPECT_EQ(backlog.counters().dropped_full, 100u - got.size());
}

TEST(ScanBacklog, ACapacityOfOneKeepsTheNewest) {
  llc::ScanBacklog<int> backlog(options(1, 0.0));
  EXPECT_EQ(backlog.push(1, 0.1), 0u);
  EXPECT_EQ(backlog.push(2, 0.2), 1u);
  int item = -1;
  ASSERT_TRUE(backlog.pop(&item));
  EXPECT_EQ(item, 2);
}

TEST(ScanBacklog, AConsumerBehindByMoreThanMaxLagSkipsTheOldestButKeepsTheNewest) {
  llc::ScanBacklog<int> backlog(options(100, 2.0));
  for (int k = 0; k < 10; ++k) backlog.push(k, double(k));  // stamps 0..9 s
  int item = -1;
  ASSERT_TRUE(backlog.pop(&item));
  EXPECT_EQ(item, 7);  // 9 - 7 = 2 s is not more than max_lag; 0..6 are skipped
  llc::ScanBacklogCounters c = backlog.counters();
  EXPECT_EQ(c.dropped_behind, 7u);
  EXPECT_DOUBLE_EQ(c.lag, 2.0);
  EXPECT_DOUBLE_EQ(c.largest_lag, 2.0);
  ASSERT_TRUE(backlog.pop(&item));
  EXPECT_EQ(item, 8);
  ASSERT_TRUE(backlog.pop(&item));
  EXPECT_EQ(item, 9);
  c = backlog.counters();
  EXPECT_DOUBLE_EQ(c.lag, 0.0);
  EXPECT_DOUBLE_EQ(c.largest_lag, 2.0);
  EXPECT_EQ(c.popped, 3u);
  EXPECT_EQ(c.waiting, 0u);

  // One scan far behind the one before it, but the only one waiting: handed out, not skipped.
  backlog.push(10, 100.0);
  ASSERT_TRUE(backlog.pop(&item));
  EXPECT_EQ(item, 10);
  EXPECT_EQ(backlog.counters().dropped_behind, 7u);
}

TEST(ScanBacklog, WithoutMaxLagEveryScanIsHandedOutInOrder) {
  llc::ScanBacklog<int> backlog(options(100, 0.0));
  for (int k = 0; k < 50; ++k) backlog.push(k, double(k));
  for (int k = 0; k < 50; ++k) {
    int item = -1;
    ASSERT_TRUE(backlog.pop(&item));
    EXPECT_EQ(item, k);
  }
  const llc::ScanBacklogCounters c = backlog.counters();
  EXPECT_EQ(c.dropped_behind + c.dropped_full, 0u);
  EXPECT_DOUBLE_EQ(c.largest_lag, 49.0);
}

TEST(ScanBacklog, StampsThatJumpBackGiveNoNegativeLag) {
  llc::ScanBacklog<int> backlog(options(10, 2.0));
  backlog.push(0, 50.0);
  backlog.push(1, 1.0);  // a looped bag: the newest is 1 s now
  int item = -1;
  ASSERT_TRUE(backlog.pop(&item));
  EXPECT_EQ(item, 0);  // 1 - 50 < 2: not behind
  EXPECT_DOUBLE_EQ(backlog.counters().lag, 0.0);
}

TEST(ScanBacklog, StopWakesAWaitingConsumer) {
  llc::ScanBacklog<int> backlog(options(10, 0.0));
  bool popped = true;
  std::thread consumer([&] {
    int item;
    popped = backlog.pop(&item);
  });
  backlog.stop();
  consumer.join();
  EXPECT_FALSE(popped);
  int item;
  backlog.push(1, 1.0);
  EXPECT_FALSE(backlog.pop(&item)) << "a stopped backlog hands out nothing";
}

TEST(ScanBacklog, AConsumerThreadGetsEveryScanAProducerPushes) {
  llc::ScanBacklog<int> backlog(options(1000, 0.0));
  long sum = 0;
  std::thread consumer([&] {
    int item;
    for (int k = 0; k < 500 && backlog.pop(&item); ++k) sum += item;
  });
  for (int k = 0; k < 500; ++k) backlog.push(k, 0.01 * k);
  consumer.join();
  EXPECT_EQ(sum, 499L * 500L / 2L);
}

TEST(ScanBacklog, PostedTasksRunOnTheConsumerBeforeTheScansWaitingAndAreNeverDropped) {
  llc::ScanBacklog<int> backlog(options(2, 0.0));
  std::vector<std::string> log;
  backlog.push(1, 1.0);
  for (int k = 0; k < 5; ++k) backlog.post([&log, k] { log.push_back("task " + std::to_string(k)); });
  backlog.push(2, 2.0);
  backlog.push(3, 3.0);  // the queue of 2 drops a scan, never a task
  int item = 0;
  ASSERT_TRUE(backlog.pop(&item));
  log.push_back("scan " + std::to_string(item));
  EXPECT_EQ(log, (std::vector<std::string>{"task 0", "task 1", "task 2", "task 3", "task 4", "scan 2"}));
  // A consumer waiting with no scan runs a task posted from another thread at once, on its own
  // thread, and goes on waiting for a scan.
  ASSERT_TRUE(backlog.pop(&item));  // scan 3: the queue is empty now
  std::promise<std::thread::id> ran_on;
  std::thread consumer([&] {
    int next = 0;
    if (backlog.pop(&next)) log.push_back("scan " + std::to_string(next));
  });
  backlog.post([&] { ran_on.set_value(std::this_thread::get_id()); });
  EXPECT_EQ(ran_on.get_future().get(), consumer.get_id());
  backlog.push(4, 4.0);
  consumer.join();
  EXPECT_EQ(log.back(), "scan 4");
}

TEST(ScanBacklog, ZeroCapacityIsRefused) { EXPECT_NE(options(0, 1.0).validate(), ""); }

}  // namespace
