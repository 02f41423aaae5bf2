// CallbackTiming: the callback latencies a nodelet's diagnostics tell (count, longest, mean,
// median and 99th percentile), against values worked out by hand.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <string>

#include "laser_loop_closure/ros/io/callback_timing.hpp"

namespace {

std::map<std::string, double> valuesOf(const diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::map<std::string, double> values;
  for (const auto& kv : status.values) values[kv.key] = std::stod(kv.value);
  return values;
}

TEST(CallbackTiming, TellsTheMedianAndP99ToTenPercentAndTheLongestExactly) {
  llc_ros::CallbackTiming timing;
  EXPECT_EQ(timing.quantile(0.5), 0.0);  // nothing yet
  for (int i = 0; i < 50; ++i) timing.record(0.001);
  for (int i = 0; i < 49; ++i) timing.record(0.010);
  timing.record(0.100);
  // Sorted, the 50th of 100 calls took 1 ms, the 99th 10 ms, the 100th 100 ms.
  EXPECT_GE(timing.quantile(0.5), 0.001);
  EXPECT_LE(timing.quantile(0.5), 0.0011);
  EXPECT_GE(timing.quantile(0.99), 0.010);
  EXPECT_LE(timing.quantile(0.99), 0.011);
  EXPECT_DOUBLE_EQ(timing.quantile(1.0), 0.100);  // never above the longest

  diagnostic_updater::DiagnosticStatusWrapper status;
  timing.addTo(status, "updates");
  const auto values = valuesOf(status);
  EXPECT_EQ(values.at("updates: calls"), 100.0);
  EXPECT_NEAR(values.at("updates: longest (ms)"), 100.0, 1e-9);
  EXPECT_NEAR(values.at("updates: mean (ms)"), (50 * 1.0 + 49 * 10.0 + 100.0) / 100.0, 1e-9);
  EXPECT_NEAR(values.at("updates: median (ms)"), 1.05, 0.05);
  EXPECT_NEAR(values.at("updates: p99 (ms)"), 10.5, 0.5);
}

TEST(CallbackTiming, OddDurationsLandInTheEndBinsAndBreakNothing) {
  llc_ros::CallbackTiming timing;
  timing.record(0.0);
  timing.record(-1.0);
  timing.record(std::numeric_limits<double>::quiet_NaN());
  timing.record(1e6);  // beyond the last bin's edge: counted there
  EXPECT_EQ(timing.quantile(0.5), 1e-6);  // the first bin's edge
  EXPECT_DOUBLE_EQ(timing.quantile(1.0), 1e6);  // the longest
}

}  // namespace
