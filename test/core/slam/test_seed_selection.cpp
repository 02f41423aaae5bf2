// The one rule that picks a step's pose among its seeds (selectSeed), and its measure
// (SeedScorer: the scan's mean likelihood in the target's field).
#include <gtest/gtest.h>

#include <cmath>

#include "laser_loop_closure/core/geometry/point_cloud.hpp"
#include "laser_loop_closure/core/slam/seed_selection.hpp"
#include "../synthetic_room.hpp"

namespace {

using llc::Pose2;
using llc::SeedCandidate;
using llc::SeedSource;

constexpr double kMargin = 0.1;

SeedCandidate at(SeedSource source, double score, double x = 0.0) { return {source, Pose2{x, 0.0, 0.0}, score}; }

TEST(SelectSeed, TheIncumbentStandsOnATieAndWithinTheMargin) {
  EXPECT_EQ(llc::selectSeed({}, kMargin), 0u);
  EXPECT_EQ(llc::selectSeed({at(SeedSource::kWheels, 0.6)}, kMargin), 0u);
  EXPECT_EQ(llc::selectSeed({at(SeedSource::kWheels, 0.6), at(SeedSource::kTracked, 0.6)}, kMargin), 0u);
  EXPECT_EQ(llc::selectSeed({at(SeedSource::kWheels, 0.6), at(SeedSource::kTracked, 0.69)}, kMargin), 0u);
  // A challenger that scores lower never wins, whatever the margin.
  EXPECT_EQ(llc::selectSeed({at(SeedSource::kWheels, 0.6), at(SeedSource::kTracked, 0.2)}, 0.0), 0u);
}

TEST(SelectSeed, EachSeedWinsWhereItFitsByTheMarginMore) {
  // Hand-worked: 0.5 + 0.1 <= 0.6 for each challenger against the step's own pose.
  for (const SeedSource challenger : {SeedSource::kTracked, SeedSource::kPredicted, SeedSource::kSearched,
                                      SeedSource::kSearchGrid, SeedSource::kRealigned}) {
    EXPECT_EQ(llc::selectSeed({at(SeedSource::kWheels, 0.5), at(challenger, 0.6)}, kMargin), 1u)
        << llc::seedSourceName(challenger);
  }
  // The wheels' seed against the tracked one, when it is the tracked step that is in question.
  EXPECT_EQ(llc::selectSeed({at(SeedSource::kTracked, 0.4), at(SeedSource::kWheels, 0.55)}, kMargin), 1u);
}

TEST(SelectSeed, ALaterSeedMustBeatTheChoiceSoFarNotOnlyTheIncumbent) {
  // Recovery's order: the best the wheels allow, the searched ICP, the wheels' ICP, the grid.
  const std::vector<SeedCandidate> recovery{at(SeedSource::kWheels, 0.40), at(SeedSource::kSearched, 0.70, 1.0),
                                            at(SeedSource::kWheels, 0.75, 2.0), at(SeedSource::kSearchGrid, 0.78, 3.0)};
  // 0.70 beats 0.40 by 0.1; 0.75 and 0.78 are within 0.1 of 0.70: the searched ICP stands.
  EXPECT_EQ(llc::selectSeed(recovery, kMargin), 1u);
  auto grid_clearly_better = recovery;
  grid_clearly_better[3].score = 0.81;
  EXPECT_EQ(llc::selectSeed(grid_clearly_better, kMargin), 3u);
  // Margin 0: the plain best, the first of equals.
  EXPECT_EQ(llc::selectSeed(recovery, 0.0), 3u);
  EXPECT_EQ(llc::selectSeed({at(SeedSource::kWheels, 0.5), at(SeedSource::kTracked, 0.5)}, 0.0), 1u);
}

TEST(SelectSeed, AFailedSeedNeverWinsAndAFailedIncumbentYieldsToAnyRealOne) {
  EXPECT_EQ(llc::selectSeed({at(SeedSource::kWheels, 0.3), at(SeedSource::kTracked, -1.0)}, 0.0), 0u);
  EXPECT_EQ(llc::selectSeed({at(SeedSource::kWheels, -1.0), at(SeedSource::kTracked, 0.05)}, kMargin), 1u);
  EXPECT_EQ(llc::selectSeed({at(SeedSource::kWheels, -1.0), at(SeedSource::kTracked, -1.0)}, kMargin), 0u);
  EXPECT_EQ(llc::selectSeed({at(SeedSource::kWheels, -1.0), at(SeedSource::kTracked, std::nan(""))}, kMargin), 0u);
}

TEST(SeedScorer, ScoresTheTruePoseHighestAndOnlyBuildsItsFieldWhenAsked) {
  const auto walls = llc_test::room();
  const Pose2 truth{0.4, -0.1, 0.05};
  const llc::Points2 target = llc::scanPoints(llc_test::scanAt(walls, Pose2{}, 720, 0.0, 1), 30.0);
  const llc::Points2 scan = llc::scanPoints(llc_test::scanAt(walls, truth, 720, 0.0, 2), 30.0);
  const llc::SeedScorer scorer(target, llc::CorrelativeSearchOptions{});
  const double right = scorer.score(scan, truth);
  EXPECT_GT(right, 0.8);
  // 0.1 m off is two of the field's sigmas: exp(-2) at most per point.
  EXPECT_LT(scorer.score(scan, Pose2{truth.x + 0.1, truth.y, truth.theta}), right - 0.3);
  EXPECT_LT(scorer.score(scan, Pose2{truth.x, truth.y, truth.theta + 0.05}), right - 0.3);
  EXPECT_EQ(scorer.score(llc::Points2{}, truth), 0.0);
}

}  // namespace
