// The fast kernels behind the features against the plain formulas they replace: the rank
// selector against a full sort, the run finder by hand, the branch-free angle against
// std::atan2, the vectorised distance loops against scalar ones (bit for bit), and the
// per-sector product of the range profile against a sum of logarithms.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "laser_loop_closure/core/features/feature_kernels.hpp"
#include "laser_loop_closure/core/common/random.hpp"
#include "laser_loop_closure/core/features/range_profile.hpp"
#include "laser_loop_closure/core/common/rank_selection.hpp"
#include "laser_loop_closure/core/common/vector_kernels.hpp"

namespace {

TEST(RankSelector, EveryRankEqualsTheFullSortOnSpreadAndClusteredValues) {
  llc::Random random(7);
  // Counts from 1 to 3000 cover both the one-lane (< kFewValues) and the four-lane path.
  for (int trial = 0; trial < 80; ++trial) {
    const auto scale = trial % 2 ? llc::RankSelector::Scale::kSquaredDistances : llc::RankSelector::Scale::kDistances;
    const std::size_t count = 1 + std::size_t(random.uniform() * 3000);
    std::vector<double> values(count);
    for (double& v : values) {
      const double kind = random.uniform();
      if (kind < 0.3) v = 5.0 + 0.001 * std::floor(random.uniform() * 20);  // a wall: many equal or close values
      else if (kind < 0.4) v = 0.0;
      else if (kind < 0.45) v = 1e-9 * random.uniform();      // below the first bucket of either scale
      else if (kind < 0.5) v = 1e5 + 1e6 * random.uniform();  // beyond the last bucket of either scale
      else if (kind < 0.52) v = -random.uniform();            // negative: the first bucket, still exact
      else v = 80.0 * random.uniform();
    }
    std::vector<double> sorted = values;
    std::sort(sorted.begin(), sorted.end());
    llc::RankSelector selector;
    selector.assign(values.data(), count, scale);
    ASSERT_EQ(selector.size(), count);
    // Ranks in a scrambled order, several per bucket.
    for (std::size_t k = 0; k < count; k += 1 + count / 37) EXPECT_EQ(selector.at((k * 7919) % count), sorted[(k * 7919) % count]);
    EXPECT_EQ(selector.at(0), sorted.front());
    EXPECT_EQ(selector.at(count - 1), sorted.back());
  }
}

TEST(RankSelector, RefusesARankBeyondTheValuesAndHandlesNone) {
  llc::RankSelector selector;
  selector.assign(nullptr, 0);
  EXPECT_EQ(selector.size(), 0u);
  EXPECT_THROW(selector.at(0), std::out_of_range);
  const double one = 2.5;
  selector.assign(&one, 1);
  EXPECT_EQ(selector.at(0), 2.5);
  EXPECT_THROW(selector.at(1), std::out_of_range);
}

TEST(SquaredDistancesAhead, RootIsBitForBitTheDistance) {
  llc::Random random(11);
  std::vector<double> x(300), y(300);
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = 40.0 * random.uniform() - 20.0, y[i] = 40.0 * random.uniform() - 20.0;
  for (const std::size_t separation : {1u, 7u, 150u}) {
    std::vector<double> distances(x.size()), squares(x.size());
    llc::distancesAhead(x.data(), y.data(), x.size(), separation, distances.data());
    llc::squaredDistancesAhead(x.data(), y.data(), x.size(), separation, squares.data());
    for (std::size_t i = 0; i + separation < x.size(); ++i) ASSERT_EQ(std::sqrt(squares[i]), distances[i]);
    const double dx = x[separation] - x[0], dy = y[separation] - y[0];
    EXPECT_DOUBLE_EQ(squares[0], dx * dx + dy * dy);
  }
}

TEST(FindRuns, OpenAndClosedSequencesByHand) {
  std::uint32_t first[16], last[16];
  //                                 0  1  2  3  4  5  6  7
  const std::uint8_t flags[8] = {1, 1, 0, 1, 1, 1, 0, 1};
  ASSERT_EQ(llc::findRuns(flags, nullptr, 8, false, first, last), 3u);  // open: [0,1] [3,5] [7,7]
  EXPECT_EQ(first[0], 0u); EXPECT_EQ(last[0], 1u);
  EXPECT_EQ(first[1], 3u); EXPECT_EQ(last[1], 5u);
  EXPECT_EQ(first[2], 7u); EXPECT_EQ(last[2], 7u);
  ASSERT_EQ(llc::findRuns(flags, nullptr, 8, true, first, last), 2u);  // closed: [3,5] and [7,1] through the seam
  EXPECT_EQ(first[0], 3u); EXPECT_EQ(last[0], 5u);
  EXPECT_EQ(first[1], 7u); EXPECT_EQ(last[1], 1u);
  // A missing link breaks a run of set flags: 3-4 not linked.
  const std::uint8_t links[8] = {1, 1, 1, 0, 1, 1, 1, 1};
  ASSERT_EQ(llc::findRuns(flags, links, 8, true, first, last), 3u);
  EXPECT_EQ(first[0], 3u); EXPECT_EQ(last[0], 3u);
  EXPECT_EQ(first[1], 4u); EXPECT_EQ(last[1], 5u);
  EXPECT_EQ(first[2], 7u); EXPECT_EQ(last[2], 1u);
  const std::uint8_t all[3] = {1, 1, 1}, none[3] = {0, 0, 0};
  EXPECT_EQ(llc::findRuns(all, nullptr, 3, true, first, last), 0u);  // one ring with no ends: the caller's case
  ASSERT_EQ(llc::findRuns(all, nullptr, 3, false, first, last), 1u);
  EXPECT_EQ(first[0], 0u); EXPECT_EQ(last[0], 2u);
  EXPECT_EQ(llc::findRuns(none, nullptr, 3, true, first, last), 0u);
  EXPECT_EQ(llc::findRuns(none, nullptr, 0, true, first, last), 0u);
}

TEST(AngleBetween, MatchesAtan2ToAFewUlpsIncludingNearParallelAndOpposite) {
  llc::Random random(3);
  double worst = 0.0;
  for (int i = 0; i < 200000; ++i) {
    const double ux = 2 * random.uniform() - 1, uy = 2 * random.uniform() - 1;
    double vx = 2 * random.uniform() - 1, vy = 2 * random.uniform() - 1;
    if (i % 3 == 0) vx = ux * (1 + 1e-9 * random.uniform()), vy = uy;    // nearly parallel
    if (i % 3 == 1 && i % 2 == 0) vx = -ux * 3, vy = -uy * 3 + 1e-12;     // nearly opposite
    const double reference = std::atan2(std::abs(ux * vy - uy * vx), ux * vx + uy * vy);
    const double value = llc::angleBetween(ux, uy, vx, vy);
    ASSERT_TRUE(value >= 0.0 && value <= M_PI + 1e-15) << value;
    worst = std::max(worst, std::abs(value - reference) / std::max(reference, 1e-300));
  }
  EXPECT_LT(worst, 1e-15);
  // Hand-worked: right angle, straight on, reversal, 45 degrees; zero vectors give 0.
  EXPECT_DOUBLE_EQ(llc::angleBetween(1, 0, 0, 1), M_PI / 2);
  EXPECT_DOUBLE_EQ(llc::angleBetween(1, 0, 0, -1), M_PI / 2);
  EXPECT_EQ(llc::angleBetween(1, 0, 2, 0), 0.0);
  EXPECT_DOUBLE_EQ(llc::angleBetween(1, 0, -2, 0), M_PI);
  EXPECT_DOUBLE_EQ(llc::angleBetween(1, 0, 1, 1), M_PI / 4);
  EXPECT_EQ(llc::angleBetween(0, 0, 1, 1), 0.0);
  EXPECT_EQ(llc::angleBetween(0, 0, 0, 0), 0.0);
}

TEST(VectorKernels, DistancesAndTurnsEqualTheScalarFormulasBitForBit) {
  llc::Random random(11);
  const std::size_t n = 723;  // not a multiple of any vector width
  std::vector<double> x(n), y(n);
  for (std::size_t i = 0; i < n; ++i) x[i] = 60 * random.uniform() - 30, y[i] = 60 * random.uniform() - 30;
  for (const std::size_t separation : {std::size_t(1), std::size_t(2), n / 4, n - 1, n, n + 5}) {
    std::vector<double> out(n, -7.0);
    llc::distancesAhead(x.data(), y.data(), n, separation, out.data());
    for (std::size_t i = 0; i + separation < n; ++i)
      ASSERT_EQ(out[i], std::sqrt((x[i + separation] - x[i]) * (x[i + separation] - x[i]) +
                                  (y[i + separation] - y[i]) * (y[i + separation] - y[i])));
    for (std::size_t i = separation < n ? n - separation : 0; i < n; ++i) ASSERT_EQ(out[i], -7.0) << "written past the end";
  }
  std::vector<double> centred(n), turns(n, -7.0);
  llc::distancesFromCentred(x.data(), y.data(), n, 1.5, -2.0, 0.25, 0.5, centred.data());
  llc::turnAngles(x.data(), y.data(), n, turns.data());
  for (std::size_t i = 0; i < n; ++i) {
    const double u = (x[i] - 1.5) - 0.25, v = (y[i] + 2.0) - 0.5;
    ASSERT_EQ(centred[i], std::sqrt(u * u + v * v));
    if (i + 2 < n) {
      ASSERT_EQ(turns[i], llc::angleBetween(x[i + 1] - x[i], y[i + 1] - y[i], x[i + 2] - x[i + 1], y[i + 2] - y[i + 1]));
    }
  }
  EXPECT_EQ(turns[n - 2], -7.0);
  EXPECT_EQ(turns[n - 1], -7.0);
}

TEST(RangeProfile, PerSectorProductEqualsTheSumOfLogarithms) {
  llc::Random random(5);
  // Many beams per sector with extreme ranges, so the product must be folded on the way.
  const std::size_t n = 36 * 400;
  std::vector<double> bearings(n), ranges(n);
  for (std::size_t i = 0; i < n; ++i) {
    bearings[i] = -M_PI + 2 * M_PI * (double(i) + 0.5) / double(n);
    ranges[i] = i % 5 == 0 ? 0.1 : (i % 7 == 0 ? 5000.0 : 1.0 + 79.0 * random.uniform());
  }
  std::vector<double> profile(llc::kProfileSectors);
  llc::writeRangeProfile(bearings.data(), ranges.data(), n, profile.data());
  for (std::size_t s = 0; s < llc::kProfileSectors; ++s) {
    double sum = 0.0;
    for (std::size_t i = s * 400; i < (s + 1) * 400; ++i) sum += std::log(ranges[i]);
    EXPECT_NEAR(profile[s], sum / 400, 1e-12) << "sector " << s;
  }
  EXPECT_EQ(llc::profileSector(std::numeric_limits<double>::quiet_NaN()), llc::kProfileSectors);
  EXPECT_EQ(llc::profileSector(-M_PI), 0u);
  EXPECT_EQ(llc::profileSector(M_PI), 0u);  // wraps to -pi
  EXPECT_EQ(llc::profileSector(3 * M_PI - 1e-9), llc::kProfileSectors - 1);
}

}  // namespace
