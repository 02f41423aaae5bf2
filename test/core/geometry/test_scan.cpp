#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "laser_loop_closure/core/features/features.hpp"
#include "laser_loop_closure/core/features/range_profile.hpp"
#include "laser_loop_closure/core/geometry/scan.hpp"
#include "laser_loop_closure/core/geometry/se2.hpp"
#include "../test_util.hpp"

namespace {

TEST(Se2, ComposeAndInverse) {
  const llc::Pose2 a{1.0, 2.0, M_PI / 2};
  const llc::Pose2 b{1.0, 0.0, 0.0};
  const llc::Pose2 c = llc::compose(a, b);  // one metre ahead of a, which faces +y
  EXPECT_NEAR(c.x, 1.0, 1e-12);
  EXPECT_NEAR(c.y, 3.0, 1e-12);
  const llc::Pose2 identity = llc::compose(a, llc::inverse(a));
  EXPECT_NEAR(identity.x, 0.0, 1e-12);
  EXPECT_NEAR(identity.y, 0.0, 1e-12);
  EXPECT_NEAR(identity.theta, 0.0, 1e-12);
  const llc::Pose2 back = llc::between(a, c);
  EXPECT_NEAR(back.x, 1.0, 1e-12);
  EXPECT_NEAR(back.y, 0.0, 1e-12);
  EXPECT_NEAR(llc::normalizeAngle(3 * M_PI), -M_PI, 1e-12);
}

TEST(Scan, CarmenGeometryEvenAndOdd) {
  EXPECT_NEAR(llc::carmenFlaserGeometry(180).angle_increment, M_PI / 180, 1e-15);
  EXPECT_NEAR(llc::carmenFlaserGeometry(361).angle_increment, M_PI / 360, 1e-15);
  EXPECT_NEAR(llc::carmenFlaserGeometry(361).angle_min, -M_PI / 2, 1e-15);
}

TEST(Scan, FrontAndBackMergeIntoFullCircleInBaseFrame) {
  // Both scanners see a circular wall of radius 5 around the base origin, mounted 1 m ahead
  // and 1 m behind. Their ranges from their own origins are computed exactly.
  const std::size_t n = 181;
  const llc::ScannerGeometry g{-M_PI / 2, M_PI / double(n - 1), 0.0};
  auto rangesFrom = [&](double offset_x, double facing) {
    std::vector<double> ranges(n);
    for (std::size_t i = 0; i < n; ++i) {
      const double beam = facing + g.angle_min + double(i) * g.angle_increment;
      // |(offset_x,0) + t (cos,sin)| = 5
      const double b = offset_x * std::cos(beam);
      ranges[i] = -b + std::sqrt(b * b - (offset_x * offset_x - 25.0));
    }
    return ranges;
  };
  const llc::Scan front = llc::scanFromRanges(rangesFrom(1.0, 0.0), g, {1.0, 0.0, 0.0});
  const llc::Scan back = llc::scanFromRanges(rangesFrom(-1.0, M_PI), g, {-1.0, 0.0, M_PI});
  const llc::Scan merged = llc::mergeScans(front, back);
  ASSERT_EQ(merged.size(), 2 * n);
  EXPECT_TRUE(merged.full_circle);
  for (std::size_t i = 0; i < merged.size(); ++i) {
    EXPECT_NEAR(merged.ranges[i], 5.0, 1e-9);  // every point lies on the wall
    if (i > 0) {
      EXPECT_LE(merged.bearings[i - 1], merged.bearings[i]);
    }
  }
  const llc::Scan resampled = llc::mergeScans(front, back, {720});
  EXPECT_EQ(resampled.size(), 720u);
}

TEST(Scan, NoReturnBeamsSurviveMounting) {
  const llc::ScannerGeometry g{-M_PI / 2, M_PI / 2, 0.0};
  const double inf = std::numeric_limits<double>::infinity();
  const llc::Scan s = llc::scanFromRanges({1.0, inf, std::nan("")}, g, {0.3, 0.0, M_PI});
  ASSERT_EQ(s.size(), 3u);
  int infinite = 0, nan = 0;
  for (double r : s.ranges) infinite += std::isinf(r), nan += std::isnan(r);
  EXPECT_EQ(infinite, 1);
  EXPECT_EQ(nan, 1);
}

TEST(Scan, RotateFullCircleByWholeBeamsIsACyclicShift) {
  std::vector<double> ranges;
  for (int i = 0; i < 8; ++i) ranges.push_back(1.0 + i);
  const llc::Scan scan = llc_test::ringScan(ranges);
  const llc::Scan turned = llc::rotateScan(scan, 2.0 * (2.0 * M_PI / 8));  // two beams
  for (std::size_t j = 0; j < 8; ++j) {
    EXPECT_NEAR(turned.ranges[j], ranges[(j + 2) % 8], 1e-9);
    EXPECT_NEAR(turned.bearings[j], scan.bearings[j], 1e-12);
  }
  // Partial scans turn their bearings.
  llc::Scan partial = scan;
  partial.full_circle = false;
  EXPECT_NEAR(llc::rotateScan(partial, 0.5).bearings[0], scan.bearings[0] - 0.5, 1e-12);
}

TEST(Scan, RotatingAMergedScanByAnyAngleKeepsEveryClosedRingFeature) {
  // A front and a back scanner at different offsets merge into unevenly spaced beams; a turn
  // by an angle that is no multiple of anything must leave the points' shape, and with it
  // every scalar feature of the closed ring, unchanged (the range profile is binned by
  // bearing, so only its best-rotation distance is invariant, to a sector).
  const llc::ScannerGeometry g{-M_PI / 2, M_PI / 360, 80.0};
  std::vector<double> front, back;
  for (int i = 0; i < 361; ++i) {
    front.push_back(6.0 + 3.0 * std::sin(0.05 * i) + (i % 37 == 0 ? 1e9 : 0.0));
    back.push_back(4.0 + 0.01 * i);
  }
  const llc::Scan merged = llc::mergeScans(llc::scanFromRanges(front, g, {1.5, 0.0, 0.0}),
                                           llc::scanFromRanges(back, g, {-1.0, 0.0, M_PI}));
  ASSERT_TRUE(merged.full_circle);
  llc::FeatureExtractor extractor;
  const std::vector<double> before = extractor.extract(merged);
  const std::size_t scalars = llc::scalarFeatureCount(llc::FeatureSet::kExtended);
  for (const double angle : {2.0, -1.234, M_PI, 0.5 * M_PI / 360}) {
    const llc::Scan turned = llc::rotateScan(merged, angle);
    ASSERT_EQ(turned.size(), merged.size());
    for (std::size_t i = 1; i < turned.size(); ++i) ASSERT_LT(turned.bearings[i - 1], turned.bearings[i]);
    const std::vector<double> after = extractor.extract(turned);
    for (std::size_t f = 0; f < scalars; ++f)
      EXPECT_NEAR(after[f], before[f], 1e-9 * std::max(1.0, std::abs(before[f])))
          << llc::featureNames(llc::FeatureSet::kExtended)[f] << " at " << angle;
    EXPECT_LT(llc::profileDistance(before.data() + scalars, after.data() + scalars), 0.35);
  }
}

}  // namespace
