// The range profile and its distance at the best rotation, by hand and as invariants.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "laser_loop_closure/core/features/features.hpp"
#include "laser_loop_closure/core/common/random.hpp"
#include "laser_loop_closure/core/features/range_profile.hpp"

namespace {

using llc::kProfileSectors;

/// Beams at the middle of equal slices of [-pi, pi) (or of the front half), `per_sector` per sector.
llc::Scan sliceScan(const std::vector<double>& ranges, bool full_circle) {
  llc::Scan scan;
  scan.ranges = ranges;
  scan.full_circle = full_circle;
  const double span = full_circle ? 2 * M_PI : M_PI, first = full_circle ? -M_PI : -M_PI / 2;
  for (std::size_t i = 0; i < ranges.size(); ++i)
    scan.bearings.push_back(first + span * (double(i) + 0.5) / double(ranges.size()));
  return scan;
}

std::vector<double> profileOf(const llc::Scan& scan) {
  llc::FeatureExtractor extractor;
  const std::vector<double> f = extractor.extract(scan);
  return std::vector<double>(f.begin() + long(llc::profileOffset(llc::FeatureSet::kExtended)), f.end());
}

TEST(RangeProfile, SectorsHoldTheMeanLogRange) {
  // Two beams per sector: 2 m and 8 m -> mean log = log 4; max-range beams count as r_max.
  std::vector<double> ranges;
  for (std::size_t s = 0; s < kProfileSectors; ++s) {
    ranges.push_back(2.0);
    ranges.push_back(s == 3 ? INFINITY : 8.0);
  }
  const std::vector<double> p = profileOf(sliceScan(ranges, true));
  ASSERT_EQ(p.size(), kProfileSectors);
  EXPECT_NEAR(p[0], std::log(4.0), 1e-12);
  EXPECT_NEAR(p[3], 0.5 * (std::log(2.0) + std::log(50.0)), 1e-12);
  // A 180-degree scan fills the front half only: sectors [-90, 90) degrees.
  const std::vector<double> front = profileOf(sliceScan(std::vector<double>(kProfileSectors, 3.0), false));
  std::size_t filled = 0;
  for (std::size_t s = 0; s < kProfileSectors; ++s) {
    if (front[s] == llc::kProfileEmpty) continue;
    ++filled;
    EXPECT_GE(s, kProfileSectors / 4);
    EXPECT_LT(s, 3 * kProfileSectors / 4);
    EXPECT_NEAR(front[s], std::log(3.0), 1e-12);
  }
  EXPECT_EQ(filled, kProfileSectors / 2);
  // A sector hidden by something nearer than 1 m on average counts as empty.
  std::vector<double> cluttered(2 * kProfileSectors, 5.0);
  cluttered[0] = cluttered[1] = 0.5;
  const std::vector<double> q = profileOf(sliceScan(cluttered, true));
  EXPECT_EQ(q[0], llc::kProfileEmpty);
  EXPECT_NEAR(q[1], std::log(5.0), 1e-12);
  // Beams with NaN or infinite bearings fall in no sector (and do not crash the binning).
  llc::Scan broken = sliceScan(std::vector<double>(2 * kProfileSectors, 5.0), true);
  broken.bearings[0] = NAN;
  broken.bearings[1] = INFINITY;
  const std::vector<double> r = profileOf(broken);
  EXPECT_EQ(r[0], llc::kProfileEmpty);
  EXPECT_NEAR(r[2], std::log(5.0), 1e-12);
}

TEST(RangeProfile, DistanceByHand) {
  std::vector<double> a(kProfileSectors), b(kProfileSectors);
  for (std::size_t s = 0; s < kProfileSectors; ++s) a[s] = std::log(1.0 + double(s % 5));
  for (std::size_t s = 0; s < kProfileSectors; ++s) b[s] = a[(s + 7) % kProfileSectors] + 0.25;
  // Best rotation undoes the 7-sector turn, leaving the constant 0.25 everywhere.
  EXPECT_NEAR(llc::profileDistance(a.data(), b.data()), 0.25, 1e-6);
  EXPECT_NEAR(llc::profileDistance(b.data(), a.data()), 0.25, 1e-6);
  EXPECT_EQ(llc::profileDistance(a.data(), a.data()), 0.0);
  // Nothing in common: a front half against a back half.
  std::vector<double> front(kProfileSectors, llc::kProfileEmpty), back = front;
  for (std::size_t s = 0; s < kProfileSectors / 2; ++s) front[s] = 1.0;
  EXPECT_EQ(llc::profileDistance(front.data(), back.data()), llc::kProfileNoOverlap);
}

TEST(RangeProfile, PairDistanceIsZeroForAnyWholeSectorTurnOfAFullScan) {
  llc::Random random(2);
  std::vector<double> ranges(3 * kProfileSectors);
  for (double& r : ranges) r = random.uniform() < 0.1 ? INFINITY : random.uniform(0.5, 30.0);
  const llc::Scan scan = sliceScan(ranges, true);
  llc::FeatureExtractor extractor;
  const std::vector<double> f = extractor.extract(scan);
  const std::size_t feature = llc::profilePairFeature(llc::FeatureSet::kExtended);
  for (std::size_t turn = 0; turn < ranges.size(); turn += 3) {  // three beams per sector
    llc::Scan turned = scan;
    for (std::size_t i = 0; i < ranges.size(); ++i) turned.ranges[i] = ranges[(i + turn) % ranges.size()];
    const std::vector<double> g = extractor.extract(turned);
    EXPECT_EQ(llc::pairFeatures(llc::FeatureSet::kExtended, f, g)[feature], 0.0) << turn;
  }
  // A different place is not at distance 0.
  std::vector<double> other(ranges.size(), 4.0);
  EXPECT_GT(llc::pairFeatures(llc::FeatureSet::kExtended, f, extractor.extract(sliceScan(other, true)))[feature], 0.3);
}

}  // namespace

namespace {

TEST(RangeProfile, GivingUpAtALimitNeverChangesADistanceBelowIt) {
  // Random profiles with empty sectors (180-degree scans leave half empty): with a limit the
  // distance is bit for bit the full one when that is below the limit, and at least the
  // limit otherwise.
  llc::Random random(21);
  std::size_t below = 0, above = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    float a[kProfileSectors], b[kProfileSectors];
    for (std::size_t s = 0; s < kProfileSectors; ++s) {
      a[s] = random.uniform() < 0.3 ? float(llc::kProfileEmpty) : float(random.uniform(0.0, 4.0));
      b[s] = random.uniform() < 0.3 ? float(llc::kProfileEmpty) : float(random.uniform(0.0, 4.0));
    }
    const double full = llc::profileDistance(a, b);
    const double limit = random.uniform(0.2, 1.6);
    const double limited = llc::profileDistance(a, b, limit);
    if (full < limit) {
      ++below;
      EXPECT_EQ(limited, full) << "trial " << trial;
    } else {
      ++above;
      EXPECT_GE(limited, limit) << "trial " << trial;
    }
  }
  EXPECT_GT(below, 300u);
  EXPECT_GT(above, 300u);
}

}  // namespace

namespace {

/// The definition, plainly: for every rotation t (sector s of a against sector s + t of b),
/// the absolute differences over the sectors both cover, summed in float in ascending order
/// of b's sector, divided in double by their number; the least over rotations with enough
/// overlap.
double referenceProfileDistance(const float* a, const float* b) {
  const std::size_t n = kProfileSectors;
  const float empty = float(llc::kProfileEmpty);
  int count_a = 0, count_b = 0;
  for (std::size_t s = 0; s < n; ++s) count_a += a[s] != empty, count_b += b[s] != empty;
  const int needed = std::max(1, int(std::ceil(float(llc::kProfileMinOverlap) * float(std::min(count_a, count_b)))));
  double best = llc::kProfileNoOverlap;
  for (std::size_t t = 0; t < n; ++t) {
    float sum = 0.0f;
    int shared = 0;
    for (std::size_t j = 0; j < n; ++j) {
      const float x = a[(j + n - t) % n], y = b[j];
      if (x == empty || y == empty) continue;
      sum += std::fabs(x - y);
      ++shared;
    }
    if (shared >= needed) best = std::min(best, double(sum) / double(shared));
  }
  return best;
}

TEST(RangeProfile, ComparerMatchesThePlainDefinitionBitForBit) {
  llc::Random random(33);
  for (int trial = 0; trial < 2000; ++trial) {
    float a[kProfileSectors], b[kProfileSectors];
    const double gaps_a = trial % 4 == 0 ? 0.0 : random.uniform(0.0, 0.7), gaps_b = random.uniform(0.0, 0.7);
    for (std::size_t s = 0; s < kProfileSectors; ++s) {
      a[s] = random.uniform() < gaps_a ? float(llc::kProfileEmpty) : float(random.uniform(0.0, 4.0));
      b[s] = random.uniform() < gaps_b ? float(llc::kProfileEmpty) : float(random.uniform(0.0, 4.0));
    }
    if (trial % 5 == 0) std::fill(b + kProfileSectors / 2, b + kProfileSectors, float(llc::kProfileEmpty));  // 180 degrees
    const double expected = referenceProfileDistance(a, b);
    const llc::ProfileComparer comparer(a);
    EXPECT_EQ(comparer.distance(b), expected) << "trial " << trial;
    EXPECT_EQ(llc::profileDistance(a, b), expected) << "trial " << trial;
  }
}

}  // namespace


namespace {

TEST(RangeProfile, NonFiniteSectorsGiveAValueNotACrash) {
  // Profiles from writeRangeProfile are finite; a corrupt stored row must still give a number
  // in [0, kProfileNoOverlap] (NaN differences never win the minimum), never a crash.
  float a[kProfileSectors], b[kProfileSectors];
  for (std::size_t s = 0; s < kProfileSectors; ++s) a[s] = b[s] = 1.0f + 0.1f * float(s);
  b[3] = NAN;
  b[7] = INFINITY;
  b[11] = -INFINITY;
  for (const double limit : {0.5, llc::kProfileNoOverlap}) {
    const double d = llc::ProfileComparer(a).distance(b, limit);
    EXPECT_GE(d, 0.0);
    EXPECT_LE(d, llc::kProfileNoOverlap);
  }
  // Against itself: the same value as the plain definition, NaN and inf sums included.
  EXPECT_EQ(llc::ProfileComparer(b).distance(b), referenceProfileDistance(b, b));
}

}  // namespace
