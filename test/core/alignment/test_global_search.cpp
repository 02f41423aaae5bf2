// The prior-free global search (orientation histograms, translation votes) and its use as a
// source of ICP starts in ScanAligner.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "laser_loop_closure/core/alignment/global_search.hpp"
#include "laser_loop_closure/core/alignment/scan_aligner.hpp"
#include "../synthetic_room.hpp"

namespace {

using llc::Point2;
using llc::Points2;
using llc::Pose2;

/// True when some pose among the first `count` is within metres and radians of the truth.
bool amongFirst(const llc::GlobalSearchResult& r, std::size_t count, const Pose2& truth, double metres, double radians) {
  for (std::size_t k = 0; k < r.poses.size() && k < count; ++k) {
    const Pose2& p = r.poses[k];
    if (std::hypot(p.x - truth.x, p.y - truth.y) <= metres && std::abs(llc::normalizeAngle(p.theta - truth.theta)) <= radians)
      return true;
  }
  return false;
}

TEST(GlobalSearch, NormalsAreTurnedTowardsTheScannerAndPointsThinned) {
  // A wall at x = 2 seen from the origin, points 5 cm apart, normals given pointing away.
  Points2 points, normals;
  for (int i = 0; i < 21; ++i) points.emplace_back(2.0, -0.5 + 0.05 * i), normals.emplace_back(1.0, 0.0);
  points.emplace_back(1.0, 1.0), normals.emplace_back(0.0, 0.0);  // no surface: left out
  points.emplace_back(std::nan(""), 1.0), normals.emplace_back(1.0, 0.0);  // bad point: left out
  points.emplace_back(1.0, 2.0), normals.emplace_back(std::nan(""), 0.0);  // bad normal: left out
  points.emplace_back(std::numeric_limits<double>::infinity(), 0.0), normals.emplace_back(0.0, 1.0);
  llc::GlobalSearchOptions options;
  options.sample_spacing = 0.15;
  const llc::GlobalSearchScan scan = llc::describeForGlobalSearch(points, normals, options);
  // Kept: every point at least 0.15 m from the last kept one: y = -0.5, -0.35, ..., 0.4 (7).
  ASSERT_EQ(scan.points.size(), 7u);
  EXPECT_DOUBLE_EQ(scan.points[1].y(), -0.35);
  for (const double angle : scan.normal_angles) EXPECT_NEAR(std::abs(angle), M_PI, 1e-12);
}

/// The room scans of the alignment tests: the best few poses include the truth, for turns
/// all round the circle, with no initial guess.
class GlobalSearchFinds : public ::testing::TestWithParam<double> {};

TEST_P(GlobalSearchFinds, TheTrueRelativePoseAmongItsBestHypotheses) {
  const double turn = GetParam();
  const Pose2 a{-1.0, 0.5, 0.3};
  const Pose2 b{a.x + 1.5 * std::cos(turn), a.y - 0.9 * std::sin(turn), llc::normalizeAngle(a.theta + turn)};
  const llc::ScanAligner aligner;
  const auto pa = aligner.prepare(llc_test::scanAt(llc_test::room(), a, 720, 0.005, 1));
  const auto pb = aligner.prepare(llc_test::scanAt(llc_test::room(), b, 720, 0.005, 2));
  const llc::GlobalSearchResult r = llc::searchGlobally(pa->global, pb->global, llc::GlobalSearchOptions{});
  ASSERT_FALSE(r.poses.empty()) << r.reject_reason;
  EXPECT_TRUE(r.reject_reason.empty());
  EXPECT_EQ(r.poses.size(), r.votes.size());
  for (std::size_t k = 1; k < r.votes.size(); ++k) EXPECT_GE(r.votes[k - 1], r.votes[k]);  // best first
  // Within ICP's reach (a cell and a histogram bin): the best-voted one, here.
  EXPECT_TRUE(amongFirst(r, 1, llc::between(a, b), 0.25, 0.05)) << "best " << r.poses[0].x << " " << r.poses[0].y << " "
                                                                << r.poses[0].theta;
}

INSTANTIATE_TEST_SUITE_P(Turns, GlobalSearchFinds, ::testing::Values(0.0, 0.7, M_PI / 2, 2.6, M_PI, -1.2, -2.8));

TEST(GlobalSearch, RefusesTooFewPointsAndBadOptions) {
  const llc::ScanAligner aligner;
  const auto room = aligner.prepare(llc_test::scanAt(llc_test::room(), Pose2{}));
  const llc::GlobalSearchScan empty;
  for (const auto& r : {llc::searchGlobally(empty, room->global, {}), llc::searchGlobally(room->global, empty, {})}) {
    EXPECT_TRUE(r.poses.empty());
    EXPECT_FALSE(r.reject_reason.empty());
  }
  // Translations beyond max_translation are not searched: a 1 m window cannot hold a 3 m move.
  llc::GlobalSearchOptions small;
  small.max_translation = 1.0;
  const auto moved = aligner.prepare(llc_test::scanAt(llc_test::room(), Pose2{3.0, 0.0, 0.0}));
  for (const Pose2& p : llc::searchGlobally(room->global, moved->global, small).poses) {
    EXPECT_LE(std::abs(p.x), 1.0 + small.cell);
    EXPECT_LE(std::abs(p.y), 1.0 + small.cell);
  }
  llc::GlobalSearchOptions bad;
  EXPECT_TRUE(bad.validate().empty());
  bad.angle_bin = 0.0;
  EXPECT_FALSE(bad.validate().empty());
  bad = {};
  bad.cell = -0.1;
  EXPECT_FALSE(bad.validate().empty());
  bad = {};
  bad.max_translation = 1e6;  // a vote grid of 10^14 cells
  EXPECT_FALSE(bad.validate().empty());
  bad = {};
  bad.hypotheses = 0;
  EXPECT_FALSE(bad.validate().empty());
}

TEST(Aligner, GlobalSearchAddsStartsOnlyWhenAskedAndAgrees) {
  // A clean pair: CRF-match fits it well (two-way share above global_search_below), so by
  // default the global search does not run; run
  // always (global_search_below = 1), it adds starts and the winner is the same pose.
  const Pose2 a{0.2, -0.4, 0.1}, b{1.1, 0.3, 2.0};
  llc::ScanAlignerOptions always;
  always.global_search_below = 1.0;
  const llc::ScanAligner by_default, aligner_always(always);
  const auto pa = by_default.prepare(llc_test::scanAt(llc_test::room(), a, 720, 0.005, 3));
  const auto pb = by_default.prepare(llc_test::scanAt(llc_test::room(), b, 720, 0.005, 4));
  const llc::ScanAlignmentResult r_default = by_default.align(*pa, *pb);
  const llc::ScanAlignmentResult r_always = aligner_always.align(*pa, *pb);
  ASSERT_TRUE(r_default.accepted && r_always.accepted) << r_default.reject_reason << r_always.reject_reason;
  EXPECT_TRUE(r_default.global.poses.empty());
  EXPECT_FALSE(r_always.global.poses.empty());
  EXPECT_GT(r_always.icp_poses.size(), r_default.icp_poses.size());
  EXPECT_NEAR(r_always.pose.x, r_default.pose.x, 1e-3);
  EXPECT_NEAR(r_always.pose.y, r_default.pose.y, 1e-3);
  EXPECT_NEAR(r_always.pose.theta, r_default.pose.theta, 1e-4);
}

TEST(Aligner, GlobalSearchAloneAlignsWhenCrfMatchGivesNothing) {
  // CRF-match made unable to associate anything (no node may be confident), so the only
  // starts are the global search's: the pair still aligns.
  const Pose2 a{-0.5, 0.2, -0.4}, b{0.6, 0.9, 1.9};
  llc::ScanAlignerOptions options;
  options.crf.min_associations = 100000;
  const llc::ScanAligner aligner(options);
  const auto pa = aligner.prepare(llc_test::scanAt(llc_test::room(), a, 720, 0.005, 5));
  const auto pb = aligner.prepare(llc_test::scanAt(llc_test::room(), b, 720, 0.005, 6));
  const llc::ScanAlignmentResult r = aligner.align(*pa, *pb);
  EXPECT_FALSE(r.crf.ok);
  ASSERT_TRUE(r.accepted) << r.reject_reason;
  EXPECT_FALSE(r.global.poses.empty());
  const Pose2 truth = llc::between(a, b);
  EXPECT_NEAR(r.pose.x, truth.x, 0.02);
  EXPECT_NEAR(r.pose.y, truth.y, 0.02);
  EXPECT_NEAR(llc::normalizeAngle(r.pose.theta - truth.theta), 0.0, 0.005);
}

}  // namespace
