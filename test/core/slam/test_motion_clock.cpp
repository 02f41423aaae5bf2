// The motion model's clock: stamps while they are steady, counted scans while they jitter.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>

#include "laser_loop_closure/core/slam/motion_clock.hpp"
#include "laser_loop_closure/core/slam/scan_odometry.hpp"

namespace {

TEST(MotionClock, SteadyStampsAreTheClockExactly) {
  // 10 Hz with 1 ms of jitter (a bag's driver stamps): the stamps themselves, bit for bit.
  llc::MotionClock clock;
  for (int k = 0; k < 200; ++k) {
    const double stamp = 1000.0 + 0.1 * k + ((k % 3) ? 0.001 : -0.001);
    EXPECT_EQ(clock.tick(stamp), stamp) << "scan " << k;
    EXPECT_FALSE(clock.countingScans()) << "scan " << k;
    // Judged steady once min_intervals intervals are known (the motion prior's condition).
    EXPECT_EQ(clock.stampsSteady(), k >= int(llc::MotionClock::min_intervals)) << "scan " << k;
  }
}

TEST(MotionClock, JitteringStampsAreCountedAtTheirMeanInterval) {
  // Taken every 0.2 s, stamped when written: up to 0.3 s late, so intervals run from -0.1 to
  // 0.5 s and some stamps go back (as in the Intel log).
  llc::MotionClock clock;
  const double late[] = {0.0, 0.3, 0.05, 0.25, 0.0, 0.28, 0.02, 0.1, 0.3, 0.0, 0.2};
  double previous = -1.0, first_counted = 0.0;
  int counted = 0, first_counted_scan = -1;
  for (int k = 0; k < 300; ++k) {
    const double time = clock.tick(50.0 + 0.2 * k + late[k % 11]);
    if (k >= 20) EXPECT_FALSE(clock.stampsSteady()) << "scan " << k;
    if (!clock.countingScans()) continue;
    if (counted++ == 0) first_counted = time, first_counted_scan = k;
    EXPECT_GT(time, previous) << "scan " << k << ": counted time never goes back";
    previous = time;
  }
  // Judged once min_intervals intervals are known (16 of these happen to look steady enough,
  // 17 not), then counted to the end.
  EXPECT_GE(first_counted_scan, int(llc::MotionClock::min_intervals));
  EXPECT_LE(first_counted_scan, int(llc::MotionClock::min_intervals) + 4);
  EXPECT_EQ(counted, 300 - first_counted_scan);
  // On by the mean interval, which is the scanner's 0.2 s (the median of these stamps is not).
  EXPECT_NEAR((previous - first_counted) / double(counted - 1), 0.2, 0.01);
}

TEST(MotionClock, EqualStampsAreNotCountedAndResetStartsAgain) {
  llc::MotionClock clock;
  for (int k = 0; k < 40; ++k) EXPECT_EQ(clock.tick(7.0), 7.0);  // no interval to count by
  EXPECT_FALSE(clock.countingScans());
  EXPECT_FALSE(clock.stampsSteady()) << "stamps that stand still predict nothing";
  clock.reset(10.0);
  const double late[] = {0.0, 0.3, 0.05, 0.25, 0.0, 0.28, 0.02, 0.1, 0.3, 0.0, 0.2};
  for (int k = 0; k < 40; ++k) clock.tick(10.0 + 0.2 * k + late[k % 11]);
  EXPECT_TRUE(clock.countingScans());
  // After a reset (a restored session, a bag played again) nothing is known: the stamps rule.
  clock.reset(3.0);
  EXPECT_FALSE(clock.countingScans());
  EXPECT_FALSE(clock.stampsSteady());
  EXPECT_EQ(clock.tick(3.5), 3.5);
  EXPECT_EQ(clock.tick(3.6), 3.6);
}

TEST(MotionClock, ALimitOfZeroCountsAnyIntervalsAndTheLimitIsValidated) {
  llc::MotionClock always(0.0);
  for (int k = 0; k < 40; ++k) always.tick(0.1 * k + ((k % 2) ? 0.01 : 0.0));
  EXPECT_TRUE(always.countingScans());
  EXPECT_THROW(llc::MotionClock(-1.0), std::invalid_argument);
  llc::ScanOdometryOptions options;
  options.max_stamp_jitter = -0.1;
  EXPECT_NE(options.validate().find("max_stamp_jitter"), std::string::npos);
  options.max_stamp_jitter = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(options.validate().find("max_stamp_jitter"), std::string::npos);
  options.max_stamp_jitter = std::numeric_limits<double>::infinity();  // stamps always
  EXPECT_EQ(options.validate(), "");
}

}  // namespace
