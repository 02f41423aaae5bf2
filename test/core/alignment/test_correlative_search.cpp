// The bounded correlative search: its likelihood field by hand, the pose it finds where ICP
// from a far guess cannot, what it does where nothing fixes the pose, and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "laser_loop_closure/core/alignment/correlative_search.hpp"
#include "laser_loop_closure/core/alignment/icp.hpp"
#include "../synthetic_room.hpp"

namespace {

using llc::CorrelativeSearchOptions;
using llc::LikelihoodField;
using llc::Point2;
using llc::Points2;
using llc::Pose2;

Points2 roomPoints(const Pose2& pose, std::uint64_t seed) {
  return llc::scanPoints(llc_test::scanAt(llc_test::room(), pose, 360, 0.01, seed), 30.0);
}

TEST(LikelihoodField, IsTheGaussianOfTheDistanceToTheNearestPoint) {
  CorrelativeSearchOptions options;
  options.cell = 0.01, options.sigma = 0.05;
  options.connect_distance = 0.0;  // points only (joined segments: below)
  const LikelihoodField field({Point2(1.0, 0.0), Point2(1.0, 1.0)}, options);
  // Read at cell centres' resolution: the distance is known to within half a cell's diagonal.
  EXPECT_NEAR(field.at(1.0, 0.0), 1.0, 0.02);
  EXPECT_NEAR(field.at(1.05, 0.0), std::exp(-0.5), 0.1);  // one sigma
  EXPECT_NEAR(field.at(1.0, 0.9), std::exp(-2.0), 0.05);  // two sigma from the second point
  EXPECT_EQ(field.at(1.0, 0.5), 0.0);                     // farther than 3 sigma from both
  EXPECT_EQ(field.at(-50.0, 0.0), 0.0);                   // outside the grid
  EXPECT_EQ(field.at(std::nan(""), 0.0), 0.0);
}

TEST(LikelihoodField, JoinsNearPointsAcrossTheBeamButNotAlongIt) {
  CorrelativeSearchOptions options;
  options.cell = 0.01;
  // A wall across the beams at x = 2 (points 0.8 m apart, as at a grazing angle), then a near
  // and a far surface on one bearing (a door's edge: 0.6 m along the beam).
  const LikelihoodField field({Point2(2.0, -0.4), Point2(2.0, 0.4), Point2(3.0, 3.0), Point2(3.6, 3.6)}, options);
  EXPECT_GT(field.at(2.0, 0.0), 0.9);   // between the wall's points: on the wall
  EXPECT_EQ(field.at(3.3, 3.3), 0.0);   // between the two surfaces: nothing
  options.connect_distance = 0.0;       // points only
  EXPECT_EQ(LikelihoodField({Point2(2.0, -0.4), Point2(2.0, 0.4)}, options).at(2.0, 0.0), 0.0);
}

TEST(LikelihoodField, LeavesOutPointsBeyondMaxRangeAndNonFinitePoints) {
  CorrelativeSearchOptions options;
  options.max_range = 5.0;
  const LikelihoodField field({Point2(10.0, 0.0), Point2(std::nan(""), 1.0)}, options);
  EXPECT_TRUE(field.empty());
  EXPECT_EQ(field.at(10.0, 0.0), 0.0);
}

TEST(CorrelativeScore, IsOneOnTheTargetAndFallsOffItsPose) {
  const Points2 target = roomPoints(Pose2{0.0, 0.0, 0.0}, 1);
  const LikelihoodField field(target, CorrelativeSearchOptions{});
  const double on = llc::correlativeScore(field, target, Pose2{}, 0);
  EXPECT_GT(on, 0.75);  // every point within half a cell's diagonal of itself
  EXPECT_LE(on, 1.0);
  EXPECT_LT(llc::correlativeScore(field, target, Pose2{0.5, 0.0, 0.0}, 0), 0.6 * on);
  EXPECT_LT(llc::correlativeScore(field, target, Pose2{0.0, 0.0, 0.3}, 0), 0.6 * on);
  EXPECT_EQ(llc::correlativeScore(field, Points2{}, Pose2{}, 0), 0.0);
}

/// A robot whose wheels counted a reverse as forward: the guess is 0.9 m in front, the truth
/// 0.9 m behind. The search, centred on no motion and the wheels' turn, finds the truth to
/// within its steps, and ICP from its pose lands on it.
TEST(CorrelativeSearch, FindsTheMotionWhereTheGuessIsFarOff) {
  const Pose2 truth{-0.9, 0.05, 0.12};
  const Pose2 guess{0.9, 0.0, 0.1};
  const Points2 target = roomPoints(Pose2{0.0, 0.0, 0.0}, 1);
  const Points2 source = roomPoints(truth, 2);
  CorrelativeSearchOptions wide;
  wide.max_translation = 1.5;  // the default 0.5 about each of two centres: here one window holds both
  const LikelihoodField field(target, wide);
  const llc::CorrelativeSearchResult found = llc::searchCorrelative(field, source, Pose2{0.0, 0.0, guess.theta}, wide);
  ASSERT_TRUE(found.found) << found.reject_reason;
  EXPECT_NEAR(found.pose.x, truth.x, 0.1);
  EXPECT_NEAR(found.pose.y, truth.y, 0.1);
  EXPECT_NEAR(found.pose.theta, truth.theta, 0.03);
  EXPECT_GT(found.score, llc::correlativeScore(field, source, guess, 180) + 0.3);
  EXPECT_EQ(found.poses_scored, 31u * 31u * 35u);  // +-1.5 m by 0.1 m, +-0.35 rad by 0.02 rad

  const llc::IcpTarget icp_target(target, llc::IcpOptions{});
  const llc::IcpResult from_search = llc::alignIcp(source, icp_target, found.pose, llc::IcpOptions{});
  ASSERT_TRUE(from_search.converged) << from_search.reject_reason;
  EXPECT_NEAR(from_search.pose.x, truth.x, 0.02);
  EXPECT_NEAR(from_search.pose.y, truth.y, 0.02);
  EXPECT_NEAR(from_search.pose.theta, truth.theta, 0.005);
}

/// Between two long walls every shift along them fits as well: the search keeps the centre's
/// position along the corridor (the nearest of the best), and still finds the cross offset.
TEST(CorrelativeSearch, KeepsTheCentreAlongWhatNothingFixes) {
  const Points2 target = llc::scanPoints(llc_test::scanAt(llc_test::corridor(), Pose2{0, 0, 0}, 360), 20.0);
  const Points2 source = llc::scanPoints(llc_test::scanAt(llc_test::corridor(), Pose2{0.7, 0.3, 0}, 360), 20.0);
  const LikelihoodField field(target, CorrelativeSearchOptions{});
  const llc::CorrelativeSearchResult found = llc::searchCorrelative(field, source, Pose2{}, CorrelativeSearchOptions{});
  ASSERT_TRUE(found.found);
  EXPECT_NEAR(found.pose.y, 0.3, 0.1);
  EXPECT_NEAR(found.pose.theta, 0.0, 0.03);
  EXPECT_LT(std::abs(found.pose.x), 0.75);  // no evidence for any x: not pushed to the window's edge
}

TEST(CorrelativeSearch, RefusesWhatItCannotSearch) {
  const CorrelativeSearchOptions options;
  const LikelihoodField field({Point2(1.0, 0.0)}, options);
  EXPECT_FALSE(llc::searchCorrelative(field, Points2{}, Pose2{}, options).found);
  EXPECT_FALSE(llc::searchCorrelative(LikelihoodField(Points2{}, options), {Point2(1, 0)}, Pose2{}, options).found);
  const auto bad_centre = llc::searchCorrelative(field, {Point2(1, 0)}, Pose2{std::nan(""), 0, 0}, options);
  EXPECT_FALSE(bad_centre.found);
  EXPECT_FALSE(bad_centre.reject_reason.empty());
}

/// How far a scan can slide and fit as well: along two bare walls as far as it is asked, across
/// them and in a room hardly at all; a door in one wall ends the slide there.
TEST(AmbiguousShift, IsLongAlongACorridorAndShortWhereTheScansFixThePose) {
  const CorrelativeSearchOptions options;
  const Pose2 at{0.3, 0.1, 0.02};
  // A hall 10 m wide (within 20 m, the field joins its walls' points: seen more than 10 degrees
  // off the beam). Source points within 10 m: shifted 5 m they stay within the field's 20 m.
  const std::vector<llc_test::Wall> hall = {{{-100, -5}, {100, -5}}, {{-100, 5}, {100, 5}}};
  const Points2 target = llc::scanPoints(llc_test::scanAt(hall, Pose2{0, 0, 0}, 360, 0.01, 1), 20.0);
  const Points2 source = llc::scanPoints(llc_test::scanAt(hall, at, 360, 0.01, 2), 10.0);
  const LikelihoodField field(target, options);
  // Bare walls 200 m long: every shift along them fits as well, and none across them.
  EXPECT_DOUBLE_EQ(llc::ambiguousShift(field, source, at, Point2(1, 0), 5.0, 0.1, 0.02, 180), 5.0);
  EXPECT_LE(llc::ambiguousShift(field, source, at, Point2(0, 1), 5.0, 0.1, 0.02, 180), 0.1);
  // Asking for a larger drop lets more through, never less.
  EXPECT_GE(llc::ambiguousShift(field, source, at, Point2(0, 1), 5.0, 0.1, 0.5, 180),
            llc::ambiguousShift(field, source, at, Point2(0, 1), 5.0, 0.1, 0.02, 180));

  // An irregular room fixes every direction.
  const Points2 room_target = roomPoints(Pose2{0, 0, 0}, 3);
  const Points2 room_source = roomPoints(at, 4);
  const LikelihoodField room_field(room_target, options);
  for (const Point2& direction : {Point2(1, 0), Point2(0, 1), Point2(std::sqrt(0.5), std::sqrt(0.5))})
    EXPECT_LE(llc::ambiguousShift(room_field, room_source, at, direction, 5.0, 0.1, 0.02, 180), 0.1) << direction.transpose();

  // A corridor with a recess 2 m ahead in one wall: the slide stops short of it.
  std::vector<llc_test::Wall> walls = {{{-100, -1.5}, {100, -1.5}}, {{-100, 1.5}, {2, 1.5}}, {{2, 1.5}, {2, 3}},
                                       {{2, 3}, {3, 3}}, {{3, 3}, {3, 1.5}}, {{3, 1.5}, {100, 1.5}}};
  const Points2 recess_target = llc::scanPoints(llc_test::scanAt(walls, Pose2{0, 0, 0}, 360), 20.0);
  const Points2 recess_source = llc::scanPoints(llc_test::scanAt(walls, at, 360), 20.0);
  const double recess = llc::ambiguousShift(LikelihoodField(recess_target, options), recess_source, at, Point2(1, 0), 5.0, 0.1, 0.02, 180);
  EXPECT_LT(recess, 1.0);
}

TEST(AmbiguousShift, IsZeroForWhatItCannotScore) {
  const CorrelativeSearchOptions options;
  const LikelihoodField field({Point2(1.0, 0.0), Point2(1.0, 0.05)}, options);
  EXPECT_EQ(llc::ambiguousShift(field, Points2{}, Pose2{}, Point2(1, 0), 5.0, 0.1, 0.02, 0), 0.0);
  EXPECT_EQ(llc::ambiguousShift(LikelihoodField(Points2{}, options), {Point2(1, 0)}, Pose2{}, Point2(1, 0), 5.0, 0.1, 0.02, 0), 0.0);
  EXPECT_EQ(llc::ambiguousShift(field, {Point2(1, 0)}, Pose2{std::nan(""), 0, 0}, Point2(1, 0), 5.0, 0.1, 0.02, 0), 0.0);
  EXPECT_EQ(llc::ambiguousShift(field, {Point2(1, 0)}, Pose2{}, Point2(std::nan(""), 0), 5.0, 0.1, 0.02, 0), 0.0);
  EXPECT_EQ(llc::ambiguousShift(field, {Point2(1, 0)}, Pose2{}, Point2(1, 0), 5.0, 0.0, 0.02, 0), 0.0);  // no step
}

TEST(CorrelativeSearchOptions, ValidateNamesWhatIsWrong) {
  EXPECT_EQ(CorrelativeSearchOptions{}.validate(), "");
  CorrelativeSearchOptions o;
  o.translation_step = 0.01;  // finer than the field's cell
  EXPECT_NE(o.validate().find("translation_step"), std::string::npos);
  o = CorrelativeSearchOptions{};
  o.max_translation = 50.0, o.translation_step = 0.05;  // 2001^2 translations x 35 rotations
  EXPECT_NE(o.validate().find("2e7"), std::string::npos);
  o = CorrelativeSearchOptions{};
  o.sigma = std::numeric_limits<double>::infinity();
  EXPECT_NE(o.validate().find("sigma"), std::string::npos);
}

}  // namespace
