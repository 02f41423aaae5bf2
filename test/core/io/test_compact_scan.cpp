#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <iostream>
#include <random>
#include <limits>

#include "laser_loop_closure/core/io/compact_scan.hpp"

namespace {

const double kInf = std::numeric_limits<double>::infinity();
const double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Bit for bit the same (NaN of any payload equal to NaN).
void expectSameValues(const std::vector<double>& a, const std::vector<double>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (std::isnan(a[i])) {
      EXPECT_TRUE(std::isnan(b[i])) << i;
    } else {
      EXPECT_EQ(std::memcmp(&a[i], &b[i], sizeof(double)), 0) << i << ": " << a[i] << " against " << b[i];
    }
  }
}

void expectSameScan(const llc::Scan& a, const llc::Scan& b) {
  expectSameValues(a.ranges, b.ranges);
  expectSameValues(a.bearings, b.bearings);
  EXPECT_EQ(a.stamp, b.stamp);
  EXPECT_EQ(a.full_circle, b.full_circle);
}

/// 720 beams as scan_merger resamples them, ranges as a ROS message carries them (floats).
llc::Scan messageScan(double phase) {
  llc::Scan scan;
  const double step = 2.0 * M_PI / 720.0;
  for (std::size_t j = 0; j < 720; ++j) {
    scan.bearings.push_back(double(float(-M_PI + (double(j) + 0.5) * step)));
    scan.ranges.push_back(double(float(2.0 + std::sin(phase + 0.01 * double(j)))));
  }
  scan.ranges[7] = kInf, scan.ranges[8] = kNaN, scan.ranges[9] = -1.0, scan.ranges[10] = 0.0;
  scan.stamp = 1234.5678;
  scan.full_circle = true;
  return scan;
}

TEST(CompactScan, MessageScanComesBackTheSameInAQuarterOfItsBytes) {
  const llc::Scan first = messageScan(0.0), second = messageScan(1.0);
  const auto a = std::make_shared<const llc::CompactScan>(first);
  const llc::CompactScan b(second, a.get());
  expectSameScan(a->scan(), first);
  expectSameScan(b.scan(), second);
  // Fewer bytes than floats (4 a value) for the 720 ranges and the 720 bearings, which count
  // with the first scan only; the second holds its ranges alone.
  std::cout << "720 ranges and bearings: " << a->bytes() - sizeof(llc::CompactScan) - sizeof(llc::CompactValues)
            << " bytes (floats: 5,760); the ranges alone: " << b.bytes() - sizeof(llc::CompactScan) << "\n";
  EXPECT_LT(a->bytes(), sizeof(llc::CompactScan) + sizeof(llc::CompactValues) + 720 * 4 + 720 * 4);
  EXPECT_LT(b.bytes(), sizeof(llc::CompactScan) + 720 * 4);
  EXPECT_LT(b.bytes(), a->bytes());
}

TEST(CompactScan, AnyFloatsComeBackBitForBit) {
  // Every kind of float (random bit patterns: subnormals, both zeros, infinities, NaNs with
  // payloads), runs of one value, and sign changes: the coding loses nothing.
  std::mt19937 random(5);
  std::vector<double> values;
  for (int k = 0; k < 5000; ++k) {
    const std::uint32_t bits = std::uint32_t(random());
    float value = 0.0f;
    std::memcpy(&value, &bits, sizeof(value));
    values.push_back(double(value));
  }
  for (const double special : {0.0, -0.0, kInf, -kInf, kNaN, double(std::numeric_limits<float>::denorm_min()),
                               double(std::numeric_limits<float>::max()), double(std::numeric_limits<float>::lowest())})
    for (int k = 0; k < 3; ++k) values.push_back(special);
  for (int k = 0; k < 500; ++k) values.push_back(double(float(std::sin(0.05 * k))));
  const llc::CompactValues compact(values);
  EXPECT_EQ(compact.size(), values.size());
  expectSameValues(compact.values(), values);
  EXPECT_TRUE(compact.equals(values));
  std::vector<double> other = values;
  other[4000] = double(std::nextafter(float(other[4000]), 0.0f));
  EXPECT_FALSE(compact.equals(other));
  EXPECT_TRUE(llc::CompactValues(std::vector<double>{}).values().empty());
}

TEST(CompactScan, DoublesThatAreNoFloatsStayDoubles) {
  llc::Scan scan;
  scan.ranges = {0.1, 1.0 / 3.0, kInf, -kInf, kNaN, 1e300, 5e-324};  // 0.1 is no float
  scan.bearings = {-3.0, -1.0, 0.0, 0.5, 1.0, 2.0, 3.0};            // all floats
  scan.stamp = -2.0;
  const llc::CompactScan compact(scan);
  expectSameScan(compact.scan(), scan);
  EXPECT_GE(compact.bytes(), sizeof(llc::CompactScan) + sizeof(llc::CompactValues) + 7 * 8);  // the ranges as doubles
}

TEST(CompactScan, BearingsAreSharedOnlyWhenTheSame) {
  llc::Scan a = messageScan(0.0), b = messageScan(0.0);
  b.bearings[100] = std::nextafter(b.bearings[100], 10.0);  // one beam differs by one ulp
  const llc::CompactScan first(a);
  const llc::CompactScan second(b, &first);
  expectSameScan(second.scan(), b);
  // Its own bearings, as doubles, beside its coded ranges.
  EXPECT_GE(second.bytes(), sizeof(llc::CompactScan) + sizeof(llc::CompactValues) + 720 * 8);
  EXPECT_LT(second.bytes(), sizeof(llc::CompactScan) + sizeof(llc::CompactValues) + 720 * 8 + 720 * 4);
  llc::Scan shorter = messageScan(0.0);
  shorter.ranges.pop_back(), shorter.bearings.pop_back();
  expectSameScan(llc::CompactScan(shorter, &first).scan(), shorter);
  llc::Scan nan_bearing = a;
  nan_bearing.bearings[3] = kNaN;  // kept as it came: the scan's users judge it
  const llc::CompactScan with_nan(nan_bearing, &first);
  expectSameScan(with_nan.scan(), nan_bearing);
  expectSameScan(llc::CompactScan(nan_bearing, &with_nan).scan(), nan_bearing);
}

TEST(CompactScan, EmptyAndUnevenScansAreKeptAsTheyCame) {
  const llc::Scan empty;
  expectSameScan(llc::CompactScan(empty).scan(), empty);
  llc::Scan uneven;  // a malformed scan: more ranges than bearings
  uneven.ranges = {1.0, 2.0, 3.0};
  uneven.bearings = {0.0};
  const llc::CompactScan compact(uneven, nullptr);
  expectSameScan(compact.scan(), uneven);
  EXPECT_EQ(compact.size(), 3u);
}

/// The points of `scan` (finite positive ranges), by bearing order.
std::vector<std::pair<double, double>> pointsOf(const llc::Scan& scan) {
  std::vector<std::pair<double, double>> points;
  for (std::size_t i = 0; i < scan.size(); ++i)
    if (std::isfinite(scan.ranges[i]) && scan.ranges[i] > 0.0)
      points.emplace_back(scan.ranges[i] * std::cos(scan.bearings[i]), scan.ranges[i] * std::sin(scan.bearings[i]));
  return points;
}

TEST(CompactScan, PackedForTheMapComesBackWithinHalfAStep) {
  const llc::Scan scan = messageScan(0.3);
  const double step = 0.0005;
  const auto packed = llc::mapScanAtRest(scan, step, nullptr);
  ASSERT_TRUE(packed->isPacked());
  EXPECT_EQ(packed->size(), 720u);
  EXPECT_LT(packed->bytes(), 2500u) << "a quarter of the single-precision scan's 5.9 kB at most";
  const llc::Scan back = packed->scan();
  EXPECT_EQ(back.stamp, scan.stamp);
  EXPECT_EQ(back.full_circle, scan.full_circle);
  ASSERT_EQ(back.size(), scan.size()) << "every beam, returns or not";
  const auto before = pointsOf(scan), after = pointsOf(back);
  ASSERT_EQ(before.size(), after.size());
  for (std::size_t i = 0; i < before.size(); ++i) {
    const double r = std::hypot(before[i].first, before[i].second);
    // Half a range step along, half a bearing step (step / 50 m) across, at this range.
    EXPECT_LE(std::hypot(before[i].first - after[i].first, before[i].second - after[i].second),
              0.5 * step + 0.5 * (step / 50.0) * r + 1e-9) << i;
  }
  // Step 0: kept exact, bearings shared with the scan before.
  const auto exact = llc::mapScanAtRest(scan, 0.0, nullptr);
  EXPECT_FALSE(exact->isPacked());
  expectSameScan(exact->scan(), scan);
  EXPECT_LT(llc::mapScanAtRest(messageScan(1.0), 0.0, exact.get())->bytes(), sizeof(llc::CompactScan) + 720 * 4);
}

TEST(CompactScan, AScanThatCannotBePackedIsKeptAsItCame) {
  llc::Scan scan = messageScan(0.0);
  scan.bearings[5] = kNaN;  // packScan refuses a bearing that is not finite
  const auto kept = llc::mapScanAtRest(scan, 0.0005, nullptr);
  EXPECT_FALSE(kept->isPacked());
  expectSameScan(kept->scan(), scan);
  llc::Scan uneven = messageScan(0.0);
  uneven.bearings.pop_back();
  expectSameScan(llc::mapScanAtRest(uneven, 0.0005, nullptr)->scan(), uneven);
}

TEST(CompactScan, MapScanStepIsChecked) {
  EXPECT_EQ(llc::checkMapScanStep(0.0), "");
  EXPECT_EQ(llc::checkMapScanStep(0.0005), "");
  EXPECT_NE(llc::checkMapScanStep(-0.001), "");
  EXPECT_NE(llc::checkMapScanStep(kNaN), "");
  EXPECT_NE(llc::checkMapScanStep(kInf), "");
}

}  // namespace
