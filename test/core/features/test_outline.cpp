// The resampled outline (outline.hpp) by hand, and the two signatures made from it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "laser_loop_closure/core/features/features.hpp"
#include "laser_loop_closure/core/features/outline.hpp"
#include "../test_util.hpp"

namespace {

struct Points {
  std::vector<double> x, y, step;
  std::vector<unsigned char> valid;
  void add(double px, double py, bool is_valid = true) {
    x.push_back(px);
    y.push_back(py);
    valid.push_back(is_valid);
  }
  /// step[i] = |p[i+1] - p[i]|, and the seam's on a closed ring (else 0).
  void finish(bool closed) {
    const std::size_t n = x.size();
    step.assign(n, 0.0);
    for (std::size_t i = 0; i < n; ++i)
      if (i + 1 < n || closed) step[i] = std::hypot(x[(i + 1) % n] - x[i], y[(i + 1) % n] - y[i]);
    if (!closed && n > 0) step[n - 1] = 0.0;
  }
  std::vector<std::pair<double, double>> resample(bool closed) {
    finish(closed);
    std::vector<double> ox(llc::kOutlineMaxPoints), oy(llc::kOutlineMaxPoints);
    const std::size_t k = llc::resampleOutline(x.data(), y.data(), valid.data(), step.data(), x.size(), closed,
                                               ox.data(), oy.data());
    std::vector<std::pair<double, double>> out;
    for (std::size_t i = 0; i < k; ++i) out.emplace_back(ox[i], oy[i]);
    return out;
  }
};

TEST(Outline, AStraightWallGivesAPointEverySpacingFromItsFirstPoint) {
  Points wall;
  for (int i = 0; i <= 21; ++i) wall.add(0.1 * i, 1.0);  // 2.1 m in steps of 0.1 m
  const auto out = wall.resample(false);
  ASSERT_EQ(out.size(), 9u);  // 0, 0.25, ..., 2.0; the last 0.1 m gives none
  for (std::size_t k = 0; k < out.size(); ++k) {
    EXPECT_NEAR(out[k].first, 0.25 * double(k), 1e-9);
    EXPECT_NEAR(out[k].second, 1.0, 1e-12);
  }
}

TEST(Outline, LonePointsCountAndGapsOrMissingReturnsBreakStretches) {
  Points p;
  p.add(0.0, 0.0);
  p.add(0.3, 0.0);   // joined: a 0.3 m stretch gives its start and the point at 0.25
  p.add(1.0, 0.0);   // 0.7 m away: not joined, a lone point
  p.add(1.2, 0.0, false);  // no return: breaks
  p.add(1.4, 0.0);   // lone (its neighbour before has no return)
  const auto out = p.resample(false);
  ASSERT_EQ(out.size(), 4u);
  EXPECT_NEAR(out[0].first, 0.0, 1e-12);
  EXPECT_NEAR(out[1].first, 0.25, 1e-12);
  EXPECT_NEAR(out[2].first, 1.0, 1e-12);
  EXPECT_NEAR(out[3].first, 1.4, 1e-12);
}

TEST(Outline, ALongOutlineIsSampledAtLengthOverTarget) {
  Points line;
  for (int i = 0; i < 1000; ++i) line.add(0.1 * i, -2.0);  // 99.9 m
  const auto out = line.resample(false);
  const double spacing = 99.9 / double(llc::kOutlineTarget);
  EXPECT_GE(out.size(), llc::kOutlineTarget);
  EXPECT_LE(out.size(), llc::kOutlineTarget + 1);
  for (std::size_t k = 1; k < out.size(); ++k) EXPECT_NEAR(out[k].first - out[k - 1].first, spacing, 1e-9);
}

TEST(Outline, ScatteredClutterStopsAtTheCapAndNothingIsEmptyOrBroken) {
  Points clutter;
  for (int i = 0; i < 700; ++i) clutter.add(1.0 * i, 0.0);  // 1 m apart: every point alone
  EXPECT_EQ(clutter.resample(false).size(), llc::kOutlineMaxPoints);
  Points none;
  EXPECT_TRUE(none.resample(false).empty());
  Points invalid;
  for (int i = 0; i < 5; ++i) invalid.add(0.1 * i, 0.0, false);
  EXPECT_TRUE(invalid.resample(true).empty());
}

TEST(Outline, AnUnbrokenRingIsWalkedOnceFromItsFarthestPoint) {
  Points ring;
  const int n = 360;
  for (int i = 0; i < n; ++i) {
    const double r = i == 100 ? 3.01 : 3.0, a = 2.0 * M_PI * i / n;
    ring.add(r * std::cos(a), r * std::sin(a));
  }
  const auto out = ring.resample(true);
  ASSERT_GT(out.size(), 70u);
  EXPECT_LE(out.size(), 76u);  // 2 pi 3 m / 0.25 m = 75.4
  EXPECT_DOUBLE_EQ(out[0].first, ring.x[100]);  // the farthest point comes first
  for (std::size_t k = 1; k < out.size(); ++k)
    EXPECT_NEAR(std::hypot(out[k].first - out[k - 1].first, out[k].second - out[k - 1].second), 0.25, 0.02);
}

std::size_t featureIndex(const std::string& name) {
  const std::vector<std::string>& names = llc::featureNames(llc::FeatureSet::kExtended);
  return std::size_t(std::find(names.begin(), names.end(), name) - names.begin());
}

TEST(Outline, SignaturesOfACircleAreItsRadiusAndItsChordDistribution) {
  const std::vector<double> f = llc::FeatureExtractor().extract(llc_test::ringScan(std::vector<double>(360, 3.0)));
  const std::size_t d2 = featureIndex("outline_d2_distribution_0");
  const std::size_t centre = featureIndex("outline_centroid_distance_distribution_0");
  ASSERT_LT(centre, f.size());
  for (std::size_t q = 0; q < llc::kSignatureLevels; ++q) {
    // The ring's last piece, under one spacing, gives no point: the centroid moves by about
    // R spacing / circumference = 0.04 m at most.
    EXPECT_NEAR(f[centre + q], 3.0, 0.04) << q;
    // Chords of a circle at separations spread evenly over [0, pi]: quantile p is 2 R sin(pi p / 2),
    // to within half the step between the odd separations (2 R 2 pi / 75 / 2 = 0.25 m).
    const double p = (double(q) + 0.5) / double(llc::kSignatureLevels);
    EXPECT_NEAR(f[d2 + q], 6.0 * std::sin(M_PI * p / 2.0), 0.3) << q;
    if (q > 0) {
      EXPECT_GE(f[d2 + q], f[d2 + q - 1]);
    }
  }
}

}  // namespace
