// Each feature against values worked out by hand; invariance; bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <algorithm>
#include <limits>
#include <tuple>

#include "laser_loop_closure/core/features/features.hpp"
#include "laser_loop_closure/core/common/random.hpp"
#include "../test_util.hpp"

namespace {

using llc::FeatureExtractor;
using llc::FeatureOptions;
using llc::FeatureSet;
constexpr double kTol = 1e-12;
const double kInf = std::numeric_limits<double>::infinity();

std::vector<double> paperFeatures(const llc::Scan& scan, bool closed = true) {
  FeatureOptions options;
  options.feature_set = FeatureSet::kPaper;
  options.closed_ring = closed;
  FeatureExtractor extractor(options);
  return extractor.extract(scan);
}

// Four beams, one metre, at -90, 0, 90, 180 degrees: a unit "diamond" around the robot.
llc::Scan diamond() { return llc_test::ringScan({1.0, 1.0, 1.0, 1.0}); }

TEST(Features, DiamondClosedRingByHand) {
  const std::vector<double> f = paperFeatures(diamond(), true);
  ASSERT_EQ(f.size(), 20u);
  const double r2 = std::sqrt(2.0);
  EXPECT_NEAR(f[0], 4 * std::sin(M_PI / 4), kTol);  // area: 4 pairs of 1*1*sin(90deg/2)
  EXPECT_NEAR(f[1], 1.0, kTol);                     // average range
  EXPECT_NEAR(f[2], 0.0, kTol);                     // centroid at the origin
  EXPECT_NEAR(f[3], 4 * std::sin(M_PI / 4), kTol);  // close area, step 2pi/4
  EXPECT_NEAR(f[4], 4 * r2, kTol);                  // close distance: 4 sides of sqrt 2
  EXPECT_NEAR(f[5], 1.0, 1e-9);                     // circle radius
  EXPECT_NEAR(f[6], 0.0, 1e-9);                     // circle residual
  EXPECT_NEAR(f[7], 1.0, kTol);  // curvature: triangle area 1, sides sqrt2 sqrt2 2 -> 4/4
  EXPECT_NEAR(f[8], 0.0, kTol);
  EXPECT_NEAR(f[9], 4 * r2, kTol);   // distance
  EXPECT_NEAR(f[10], 4 * r2, kTol);  // far distance
  EXPECT_EQ(f[11], 1.0);             // one group of 4 > 3 points
  EXPECT_EQ(f[12], 4.0);
  EXPECT_EQ(f[13], 0.0);                   // no max-range beam
  EXPECT_NEAR(f[14], 4 * M_PI / 2, kTol);  // four right-angle turns
  EXPECT_NEAR(f[15], 1.0, kTol);           // mean deviation
  EXPECT_NEAR(f[16], 0.0, kTol);           // regularity: equal segments
  EXPECT_EQ(f[17], 4.0);                   // size
  EXPECT_NEAR(f[18], 0.0, kTol);
  EXPECT_NEAR(f[19], 0.0, kTol);
}

TEST(Features, DiamondOpenRingDropsTheSeam) {
  const std::vector<double> f = paperFeatures(diamond(), false);
  EXPECT_NEAR(f[0], 3 * std::sin(M_PI / 4), kTol);
  EXPECT_NEAR(f[3], 4 * std::sin(M_PI / 4), kTol);  // open: step = span / (n - 1) = pi/2 too
  EXPECT_NEAR(f[9], 3 * std::sqrt(2.0), kTol);
  EXPECT_NEAR(f[14], 2 * M_PI / 2, kTol);  // two triples
  EXPECT_EQ(f[11], 1.0);
}

TEST(Features, SingleWallByHand) {
  // Beams at -45, 0, 45 degrees onto the wall x = 1: points (1,-1) (1,0) (1,1).
  llc::Scan wall;
  wall.bearings = {-M_PI / 4, 0.0, M_PI / 4};
  wall.ranges = {std::sqrt(2.0), 1.0, std::sqrt(2.0)};
  const std::vector<double> f = paperFeatures(wall);
  const double s8 = std::sin(M_PI / 8);
  EXPECT_NEAR(f[0], 2 * std::sqrt(2.0) * s8, kTol);
  EXPECT_NEAR(f[1], (2 * std::sqrt(2.0) + 1) / 3, kTol);
  EXPECT_NEAR(f[2], 1.0, kTol);     // mean point (1, 0)
  EXPECT_NEAR(f[3], 5 * s8, kTol);  // (2 + 1 + 2) sin(pi/8)
  EXPECT_NEAR(f[4], 2.0, kTol);
  EXPECT_EQ(f[5], 0.0);  // collinear: no circle
  EXPECT_EQ(f[6], 0.0);
  EXPECT_NEAR(f[7], 0.0, kTol);  // straight: zero curvature
  EXPECT_NEAR(f[9], 2.0, kTol);
  EXPECT_NEAR(f[10], 2.0, kTol);
  EXPECT_EQ(f[11], 0.0);  // three points are not more than g_min_size = 3
  EXPECT_EQ(f[12], 0.0);
  EXPECT_NEAR(f[14], 0.0, 1e-7);  // no turn (acos near 1 loses precision)
  EXPECT_NEAR(f[15], 2.0 / 3, kTol);
  EXPECT_NEAR(f[16], 0.0, kTol);
  EXPECT_EQ(f[17], 3.0);
  EXPECT_NEAR(f[18], std::sqrt(1.0 / 3), kTol);  // distances 1 0 1 to the mean
  const double m = (2 * std::sqrt(2.0) + 1) / 3;
  const double var = (2 * std::pow(std::sqrt(2.0) - m, 2) + std::pow(1 - m, 2)) / 2;
  EXPECT_NEAR(f[19], std::sqrt(var), kTol);
}

TEST(Features, CircleOfKnownRadius) {
  std::vector<double> ranges(360, 3.0);
  const std::vector<double> f = paperFeatures(llc_test::ringScan(ranges));
  EXPECT_NEAR(f[5], 3.0, 1e-9);
  EXPECT_NEAR(f[6], 0.0, 1e-9);
  EXPECT_NEAR(f[7], 1.0 / 3.0, 1e-6);  // curvature of a circle
  EXPECT_NEAR(f[2], 0.0, 1e-9);
  EXPECT_NEAR(f[9], 360 * 2 * 3.0 * std::sin(M_PI / 360), 1e-9);  // 360 chords
  EXPECT_NEAR(f[14], 2 * M_PI, 1e-9);                             // one full turn
}

TEST(Features, OffCentreCircleFitIsExact) {
  // Points of a circle of radius 2 centred at (4, 1), seen from the origin over a partial arc.
  llc::Scan scan;
  for (int i = 0; i <= 40; ++i) {
    const double t = -1.0 + 0.05 * i;  // arc parameter on the circle's far side
    const double x = 4 + 2 * std::cos(M_PI + t), y = 1 + 2 * std::sin(M_PI + t);
    scan.bearings.push_back(std::atan2(y, x));
    scan.ranges.push_back(std::hypot(x, y));
  }
  // Scans are ordered by bearing.
  std::vector<std::pair<double, double>> beams;
  for (std::size_t i = 0; i < scan.size(); ++i) beams.emplace_back(scan.bearings[i], scan.ranges[i]);
  std::sort(beams.begin(), beams.end());
  for (std::size_t i = 0; i < scan.size(); ++i) std::tie(scan.bearings[i], scan.ranges[i]) = beams[i];
  const std::vector<double> f = paperFeatures(scan);
  EXPECT_NEAR(f[5], 2.0, 1e-9);
  EXPECT_NEAR(f[6], 0.0, 1e-9);
}

TEST(Features, AllMaxRange) {
  std::vector<double> ranges(8, 60.0);
  ranges[3] = kInf;
  const std::vector<double> f = paperFeatures(llc_test::ringScan(ranges));
  const double step = 2 * M_PI / 8;
  EXPECT_NEAR(f[0], 8 * 50.0 * 50.0 * std::sin(step / 2), 1e-9);   // clipped to r_max
  EXPECT_NEAR(f[1], 50.0, kTol);
  EXPECT_NEAR(f[10], 8 * 2 * 50.0 * std::sin(step / 2), 1e-9);  // chords at r_max
  EXPECT_EQ(f[13], 8.0);
  EXPECT_EQ(f[17], 0.0);
  for (int i : {2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 14, 15, 16, 18, 19}) EXPECT_EQ(f[i], 0.0) << "feature " << i + 1;
}

TEST(Features, GroupsRespectGateAndMinimumSize) {
  // A partial scan along the wall y = 2: beams hitting x = -3..3; a no-return beam splits
  // the run into 4 and 3 points; the group of 3 is not counted (needs more than 3).
  llc::Scan scan;
  for (int i = 0; i < 8; ++i) {
    const double x = 3.0 - i;
    scan.bearings.push_back(std::atan2(2.0, x));
    scan.ranges.push_back(std::hypot(x, 2.0));
  }
  scan.ranges[4] = kInf;
  std::vector<double> f = paperFeatures(scan);
  EXPECT_EQ(f[11], 1.0);
  EXPECT_EQ(f[12], 4.0);
  EXPECT_EQ(f[13], 1.0);
  EXPECT_NEAR(f[4], 3.0 + 2.0, kTol);  // segments of 1 m inside both runs
  // A gate below the 1 m spacing breaks every link: no group at all.
  FeatureOptions tight;
  tight.feature_set = FeatureSet::kPaper;
  tight.g_max_dist = 0.5;
  FeatureExtractor extractor(tight);
  f = extractor.extract(scan);
  EXPECT_EQ(f[11], 0.0);
  EXPECT_EQ(f[4], 0.0);
  EXPECT_NEAR(f[9], 5.0, kTol);  // the ungated distance is unchanged
}

TEST(Features, BadRangesGiveFiniteValues) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  FeatureExtractor extractor;  // extended set
  std::vector<llc::Scan> scans;
  scans.push_back(llc::Scan{});                                            // empty
  scans.push_back(llc_test::ringScan({nan, kInf, -kInf, -1.0, 0.0}));     // nothing valid
  scans.push_back(llc_test::ringScan({1.0, nan, 2.0}));                    // two valid points
  scans.push_back(llc_test::ringScan({1.0, 1.0, 1.0, 1.0, nan, kInf}));   // mixed
  scans.push_back(llc_test::ringScan({2.0}));                              // one beam
  llc::Scan duplicate;  // repeated points: zero-length segments
  duplicate.bearings = {0.0, 0.0, 0.0, 0.1};
  duplicate.ranges = {1.0, 1.0, 1.0, 1.0};
  scans.push_back(duplicate);
  llc::Scan resized;  // more ranges than bearings
  resized.ranges = {1.0, 2.0, 3.0};
  resized.bearings = {0.0, 0.1};
  scans.push_back(resized);
  for (std::size_t s = 0; s < scans.size(); ++s) {
    const std::vector<double> f = extractor.extract(scans[s]);
    ASSERT_EQ(f.size(), extractor.size());
    for (std::size_t i = 0; i < f.size(); ++i)
      EXPECT_TRUE(std::isfinite(f[i])) << "scan " << s << " feature " << llc::featureNames(FeatureSet::kExtended)[i];
  }
  // NaN, -inf, negative and zero ranges are not valid points.
  const std::vector<double> f = paperFeatures(llc_test::ringScan({1.0, nan, -kInf, -2.0, 0.0, 1.0}));
  EXPECT_EQ(f[17], 2.0);
  EXPECT_EQ(f[13], 4.0);
  // Nor are beams whose bearing is NaN or infinite; everything stays finite.
  llc::Scan bad_bearings = llc_test::ringScan(std::vector<double>(40, 3.0));
  bad_bearings.bearings[5] = nan;
  bad_bearings.bearings[17] = kInf;
  const std::vector<double> g = extractor.extract(bad_bearings);
  for (std::size_t i = 0; i < g.size(); ++i)
    EXPECT_TRUE(std::isfinite(g[i])) << "feature " << llc::featureNames(FeatureSet::kExtended)[i];
  EXPECT_EQ(g[17], 38.0);
  EXPECT_EQ(g[13], 2.0);
  // A partial scan whose first or last bearing has no direction: the spacing (and the close
  // area, the widest gap's angle) from the beams that have one; the same as without those beams
  // but for their max-range count.
  llc::Scan partial;
  for (int i = 0; i < 20; ++i) partial.bearings.push_back(-0.5 + 0.05 * i), partial.ranges.push_back(2.0 + 0.1 * (i % 3));
  partial.ranges[9] = kInf;  // a gap of one beam
  llc::Scan ends = partial;
  ends.bearings.front() = nan, ends.bearings.back() = kInf;
  llc::Scan trimmed = partial;
  trimmed.bearings = std::vector<double>(partial.bearings.begin() + 1, partial.bearings.end() - 1);
  trimmed.ranges = std::vector<double>(partial.ranges.begin() + 1, partial.ranges.end() - 1);
  const std::vector<double> with_ends = extractor.extract(ends), without = extractor.extract(trimmed);
  for (std::size_t i = 0; i < with_ends.size(); ++i)
    EXPECT_TRUE(std::isfinite(with_ends[i])) << "feature " << llc::featureNames(FeatureSet::kExtended)[i];
  for (const char* name : {"close_area", "widest_gap_angle"}) {
    const auto& names = llc::featureNames(FeatureSet::kExtended);
    const std::size_t k = std::size_t(std::find(names.begin(), names.end(), name) - names.begin());
    ASSERT_LT(k, names.size()) << name;
    EXPECT_NEAR(with_ends[k], without[k], 1e-12 * (1.0 + std::abs(without[k]))) << name;
  }
  EXPECT_NEAR(with_ends[llc::featureIndex(llc::ExtraFeature::kWidestGapAngle)], 0.05, 1e-12);
}

llc::Scan randomRoomScan(std::uint64_t seed, std::size_t n) {
  llc::Random random(seed);
  std::vector<double> ranges(n);
  double r = 4.0;
  for (std::size_t i = 0; i < n; ++i) {
    r = std::clamp(r + random.uniform(-0.3, 0.3), 0.5, 60.0);
    if (random.uniform() < 0.05) r = random.uniform(0.5, 20.0);  // depth edges
    ranges[i] = random.uniform() < 0.03 ? kInf : r;
  }
  return llc_test::ringScan(ranges);
}

TEST(Features, ClosedRingIsInvariantToEveryCyclicShift) {
  FeatureExtractor closed;  // extended features, closed ring
  FeatureOptions open_options;
  open_options.closed_ring = false;
  FeatureExtractor open(open_options);
  const llc::Scan scan = randomRoomScan(7, 72);
  const std::vector<double> reference = closed.extract(scan);
  bool open_changed = false;
  const std::vector<double> open_reference = open.extract(scan);
  for (std::size_t shift = 1; shift < scan.size(); ++shift) {
    llc::Scan shifted = scan;
    for (std::size_t i = 0; i < scan.size(); ++i) shifted.ranges[i] = scan.ranges[(i + shift) % scan.size()];
    const std::vector<double> f = closed.extract(shifted);
    // The range profile is kept in the robot frame; it is compared at the best rotation.
    for (std::size_t i = 0; i < llc::scalarFeatureCount(FeatureSet::kExtended); ++i)
      EXPECT_NEAR(f[i], reference[i], 1e-9 * std::max(1.0, std::abs(reference[i])))
          << "shift " << shift << " feature " << llc::featureNames(FeatureSet::kExtended)[i];
    const std::vector<double> g = open.extract(shifted);
    for (std::size_t i = 0; i < g.size(); ++i)
      open_changed = open_changed || std::abs(g[i] - open_reference[i]) > 1e-6 * std::max(1.0, std::abs(g[i]));
  }
  EXPECT_TRUE(open_changed) << "an open ring should feel the seam";
}

TEST(Features, ExtendedCountsAreNormalisedByBeams) {
  // The same room seen at two resolutions keeps its fractions.
  FeatureExtractor extractor;
  std::vector<double> coarse(90, 5.0), fine(360, 5.0);
  for (std::size_t i = 0; i < 45; ++i) coarse[i] = kInf;
  for (std::size_t i = 0; i < 180; ++i) fine[i] = kInf;
  const auto a = extractor.extract(llc_test::ringScan(coarse));
  const auto b = extractor.extract(llc_test::ringScan(fine));
  const auto& names = llc::featureNames(FeatureSet::kExtended);
  for (const char* name : {"valid_fraction", "max_range_fraction", "range_q50", "range_hist_4_8"}) {
    const std::size_t i = std::size_t(std::find(names.begin(), names.end(), name) - names.begin());
    ASSERT_LT(i, names.size());
    EXPECT_NEAR(a[i], b[i], 1e-12) << name;
  }
  const std::size_t gap = std::size_t(std::find(names.begin(), names.end(), "widest_gap_angle") - names.begin());
  EXPECT_NEAR(a[gap], M_PI, 1e-9);
}

TEST(Features, OptionsAreValidated) {
  FeatureOptions bad;
  bad.r_max = -1.0;
  EXPECT_FALSE(bad.validate().empty());
  EXPECT_THROW(FeatureExtractor{bad}, std::invalid_argument);
  bad = FeatureOptions{};
  bad.g_max_dist = std::nan("");
  EXPECT_FALSE(bad.validate().empty());
  EXPECT_TRUE(FeatureOptions{}.validate().empty());
}

TEST(Features, NamedSlotsMatchTheNames) {
  // The named slots the extractor writes and the names a model file and the CSVs carry are
  // one layout: every enumerator against its name, and the counts.
  using llc::ExtraFeature;
  using llc::PaperFeature;
  const auto& names = llc::featureNames(FeatureSet::kExtended);
  ASSERT_EQ(llc::featureNames(FeatureSet::kPaper).size(), std::size_t(PaperFeature::kCount));
  ASSERT_EQ(llc::signatureOffset(FeatureSet::kExtended), llc::featureIndex(ExtraFeature::kCount));
  const std::vector<std::pair<std::size_t, const char*>> slots = {
      {llc::featureIndex(PaperFeature::kArea), "area"},
      {llc::featureIndex(PaperFeature::kAverageRange), "average_range"},
      {llc::featureIndex(PaperFeature::kCentroid), "centroid"},
      {llc::featureIndex(PaperFeature::kCloseArea), "close_area"},
      {llc::featureIndex(PaperFeature::kCloseDistance), "close_distance"},
      {llc::featureIndex(PaperFeature::kCircleRadius), "circle_radius"},
      {llc::featureIndex(PaperFeature::kCircleResidual), "circle_residual"},
      {llc::featureIndex(PaperFeature::kCurvatureMean), "curvature_mean"},
      {llc::featureIndex(PaperFeature::kCurvatureStd), "curvature_std"},
      {llc::featureIndex(PaperFeature::kDistance), "distance"},
      {llc::featureIndex(PaperFeature::kFarDistance), "far_distance"},
      {llc::featureIndex(PaperFeature::kGroupCount), "group_count"},
      {llc::featureIndex(PaperFeature::kGroupSizeMean), "group_size_mean"},
      {llc::featureIndex(PaperFeature::kMaxRangeCount), "max_range_count"},
      {llc::featureIndex(PaperFeature::kAngularDifference), "angular_difference"},
      {llc::featureIndex(PaperFeature::kMeanDeviation), "mean_deviation"},
      {llc::featureIndex(PaperFeature::kRegularity), "regularity"},
      {llc::featureIndex(PaperFeature::kSize), "size"},
      {llc::featureIndex(PaperFeature::kDeviationStd), "deviation_std"},
      {llc::featureIndex(PaperFeature::kRangeStd), "range_std"},
      {llc::featureIndex(ExtraFeature::kValidFraction), "valid_fraction"},
      {llc::featureIndex(ExtraFeature::kMaxRangeFraction), "max_range_fraction"},
      {llc::featureIndex(ExtraFeature::kGroupSizeFraction), "group_size_fraction"},
      {llc::featureIndex(ExtraFeature::kRangeQ10), "range_q10"},
      {llc::featureIndex(ExtraFeature::kRangeQ25), "range_q25"},
      {llc::featureIndex(ExtraFeature::kRangeQ50), "range_q50"},
      {llc::featureIndex(ExtraFeature::kRangeQ75), "range_q75"},
      {llc::featureIndex(ExtraFeature::kRangeQ90), "range_q90"},
      {llc::featureIndex(ExtraFeature::kPrincipalSigmaMajor), "principal_sigma_major"},
      {llc::featureIndex(ExtraFeature::kPrincipalSigmaMinor), "principal_sigma_minor"},
      {llc::featureIndex(ExtraFeature::kAnisotropy), "anisotropy"},
      {llc::featureIndex(ExtraFeature::kGapCount), "gap_count"},
      {llc::featureIndex(ExtraFeature::kWidestGapAngle), "widest_gap_angle"},
      {llc::featureIndex(ExtraFeature::kLongestGroupLength), "longest_group_length"},
      {llc::featureIndex(ExtraFeature::kGroupLengthMean), "group_length_mean"},
      {llc::featureIndex(ExtraFeature::kRangeHistogram), "range_hist_0_1"},
      {llc::featureIndex(ExtraFeature::kRangeHistogram) + llc::kRangeHistogramBins - 1, "range_hist_16_max"},
      {llc::signatureOffset(FeatureSet::kExtended) + std::size_t(llc::Signature::kChord) * llc::kSignatureLevels,
       "chord_distribution_0"},
      {llc::signatureOffset(FeatureSet::kExtended) +
           std::size_t(llc::Signature::kOutlineCentroidDistance) * llc::kSignatureLevels,
       "outline_centroid_distance_distribution_0"}};
  for (const auto& [index, name] : slots) {
    ASSERT_LT(index, names.size()) << name;
    EXPECT_EQ(names[index], name);
  }
}

TEST(Features, PairFeaturesAreAbsoluteThenRelativeDifferences) {
  std::vector<double> a(20, 0.0), b(20, 0.0);
  a[0] = 1.0, b[0] = 3.0, a[1] = 5.0, b[1] = 1.0;
  const std::vector<double> paper = llc::pairFeatures(FeatureSet::kPaper, a, b);
  ASSERT_EQ(paper.size(), 20u);
  EXPECT_EQ(paper[0], 2.0);
  EXPECT_EQ(paper[1], 4.0);
  EXPECT_EQ(paper[2], 0.0);
  const std::size_t n = llc::scalarFeatureCount(FeatureSet::kExtended);
  std::vector<double> c(llc::featureCount(FeatureSet::kExtended), 0.0), d = c;
  c[0] = 1.0, d[0] = 3.0, c[5] = -2.0, d[5] = 2.0;
  const std::vector<double> extended = llc::pairFeatures(FeatureSet::kExtended, c, d);
  ASSERT_EQ(extended.size(), 2 * n + 2 * llc::kSignatureCount + 1);
  EXPECT_EQ(llc::pairFeatureNames(FeatureSet::kExtended).size(), extended.size());
  EXPECT_EQ(llc::pairFeatureNames(FeatureSet::kExtended)[n], "area_relative");
  EXPECT_EQ(extended[0], 2.0);
  EXPECT_EQ(extended[n], 0.5);      // |1 - 3| / (1 + 3)
  EXPECT_EQ(extended[n + 5], 1.0);  // |-2 - 2| / (2 + 2)
  EXPECT_EQ(extended[n + 1], 0.0);  // both zero
  EXPECT_THROW(llc::pairFeatures(FeatureSet::kExtended, a, b), std::invalid_argument);
  // Signatures: quantiles all 1 against all 3 -> Wasserstein-1 distance 2, relative 2/4.
  const std::size_t first = llc::signatureOffset(FeatureSet::kExtended);
  for (std::size_t q = 0; q < llc::kSignatureLevels; ++q) c[first + q] = 1.0, d[first + q] = 3.0;
  const std::vector<double> with_signature = llc::pairFeatures(FeatureSet::kExtended, c, d);
  EXPECT_DOUBLE_EQ(with_signature[2 * n], 2.0);
  EXPECT_DOUBLE_EQ(with_signature[2 * n + llc::kSignatureCount], 0.5);
  EXPECT_DOUBLE_EQ(with_signature[2 * n + 1], 0.0);
}

}  // namespace
