// TrajectoryJoin (hand-worked stories of loops from a robot's keyframes to a map), and the
// pieces llc localize scores with: kidnapped(), startsNearMap(), scoreLocalization().
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "laser_loop_closure/core/sim/kidnap.hpp"
#include "laser_loop_closure/core/slam/localization_evaluation.hpp"
#include "laser_loop_closure/core/slam/trajectory_join.hpp"

namespace {

using llc::JoinHypothesis;
using llc::Pose2;
using llc::TrajectoryJoin;
using llc::TrajectoryJoinOptions;

/// The robot's keyframe k at (path, 0, 0) in its own frame, and a loop that puts it where the
/// trajectory frame `map_from_trajectory` says (plus `miss`, in the map frame).
JoinHypothesis loopAt(std::size_t keyframe, double path, const Pose2& map_from_trajectory, const Pose2& miss = {}) {
  JoinHypothesis h;
  h.keyframe = keyframe;
  h.path = path;
  h.trajectory_pose = {path, 0.0, 0.0};
  h.map_pose = compose(miss, compose(map_from_trajectory, h.trajectory_pose));
  return h;
}

const Pose2 kTrue{10.0, 5.0, 0.5};
const Pose2 kLookAlike{16.0, 5.0, 0.5};  // the same corridor 6 m on

TEST(TrajectoryJoin, OptionsAreValidated) {
  EXPECT_TRUE(TrajectoryJoinOptions{}.validate().empty());
  TrajectoryJoinOptions o;
  o.min_keyframes = 1;
  EXPECT_NE(o.validate().find("min_keyframes"), std::string::npos);
  o = {}, o.max_translation = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(o.validate().find("max_translation"), std::string::npos);
  o = {}, o.window = 0.5;  // not above min_spread
  EXPECT_NE(o.validate().find("window"), std::string::npos);
  EXPECT_THROW(TrajectoryJoin{o}, std::invalid_argument);
}

TEST(TrajectoryJoin, ThreeKeyframesThatAgreeJoinAndTwoDoNot) {
  TrajectoryJoin join;
  EXPECT_FALSE(join.offer({loopAt(0, 0.0, kTrue)}).joined);
  const llc::TrajectoryJoinResult two = join.offer({loopAt(1, 1.0, kTrue)});
  EXPECT_FALSE(two.joined);
  EXPECT_EQ(two.keyframes, 2u);
  EXPECT_NE(two.why_not.find("2 keyframes agree, 3 needed"), std::string::npos) << two.why_not;
  const llc::TrajectoryJoinResult three = join.offer({loopAt(2, 2.0, kTrue)});
  ASSERT_TRUE(three.joined) << three.why_not;
  EXPECT_EQ(three.support.size(), 3u);
  EXPECT_NEAR(three.map_from_trajectory.x, kTrue.x, 1e-9);
  EXPECT_NEAR(three.map_from_trajectory.y, kTrue.y, 1e-9);
  EXPECT_NEAR(three.map_from_trajectory.theta, kTrue.theta, 1e-9);
}

TEST(TrajectoryJoin, OneViewSeenThriceIsNotEnough) {
  TrajectoryJoin join;  // min_spread 1 m of path
  join.offer({loopAt(0, 0.0, kTrue)});
  join.offer({loopAt(1, 0.3, kTrue)});
  const llc::TrajectoryJoinResult r = join.offer({loopAt(2, 0.6, kTrue)});
  EXPECT_FALSE(r.joined);
  EXPECT_NE(r.why_not.find("span"), std::string::npos) << r.why_not;
}

/// Keyframe k on the spot (path `path`), turned to `heading` in the robot's frame, with a field
/// of view `view_width`, and a loop that puts it where `map_from_trajectory` says.
JoinHypothesis turnedLoopAt(std::size_t keyframe, double path, double heading, double view_width, const Pose2& map_from_trajectory) {
  JoinHypothesis h;
  h.keyframe = keyframe;
  h.path = path;
  h.trajectory_pose = {0.0, 0.0, heading};
  h.map_pose = compose(map_from_trajectory, h.trajectory_pose);
  h.view_width = view_width;
  return h;
}

TEST(TrajectoryJoin, AHalfCircleScannerTurnedOnTheSpotSeesNewViews) {
  // A 180-degree scanner turning on the spot: keyframes 0, 25 and 50 degrees round, 0.1 m of
  // path in all. 50 degrees of new view: enough (min_new_view 45 degrees).
  const double deg = M_PI / 180.0;
  TrajectoryJoin join;
  join.offer({turnedLoopAt(0, 0.0, 0.0, M_PI, kTrue)});
  join.offer({turnedLoopAt(1, 0.05, 25 * deg, M_PI, kTrue)});
  const llc::TrajectoryJoinResult turned = join.offer({turnedLoopAt(2, 0.1, 50 * deg, M_PI, kTrue)});
  ASSERT_TRUE(turned.joined) << turned.why_not;
  EXPECT_NEAR(turned.map_from_trajectory.x, kTrue.x, 1e-9);
  // Turned by 40 degrees only: not yet.
  TrajectoryJoin short_turn;
  short_turn.offer({turnedLoopAt(0, 0.0, 0.0, M_PI, kTrue)});
  short_turn.offer({turnedLoopAt(1, 0.05, 20 * deg, M_PI, kTrue)});
  const llc::TrajectoryJoinResult forty = short_turn.offer({turnedLoopAt(2, 0.1, 40 * deg, M_PI, kTrue)});
  EXPECT_FALSE(forty.joined);
  EXPECT_NE(forty.why_not.find("span"), std::string::npos) << forty.why_not;
  // A 300-degree scanner turned by 90 degrees sees only 60 new degrees: enough; a 330-degree
  // one 30: not.
  for (const auto& [width, joins] : {std::pair{300 * deg, true}, std::pair{330 * deg, false}}) {
    TrajectoryJoin wide;
    wide.offer({turnedLoopAt(0, 0.0, 0.0, width, kTrue)});
    wide.offer({turnedLoopAt(1, 0.05, 45 * deg, width, kTrue)});
    EXPECT_EQ(wide.offer({turnedLoopAt(2, 0.1, 90 * deg, width, kTrue)}).joined, joins) << width / deg;
  }
}

TEST(TrajectoryJoin, AFullCircleScannerTurnedOnTheSpotSeesTheSameView) {
  // The same turn with a 360-degree scan: one view seen thrice, however far it turns; the same
  // with min_new_view 0 (off) for any scanner.
  const double deg = M_PI / 180.0;
  TrajectoryJoin full;  // view_width defaults to the full circle
  full.offer({turnedLoopAt(0, 0.0, 0.0, 2 * M_PI, kTrue)});
  full.offer({turnedLoopAt(1, 0.05, 90 * deg, 2 * M_PI, kTrue)});
  const llc::TrajectoryJoinResult r = full.offer({turnedLoopAt(2, 0.1, 180 * deg, 2 * M_PI, kTrue)});
  EXPECT_FALSE(r.joined);
  EXPECT_NE(r.why_not.find("span"), std::string::npos) << r.why_not;
  TrajectoryJoinOptions off;
  off.min_new_view = 0.0;
  TrajectoryJoin half_off(off);
  half_off.offer({turnedLoopAt(0, 0.0, 0.0, M_PI, kTrue)});
  half_off.offer({turnedLoopAt(1, 0.05, 90 * deg, M_PI, kTrue)});
  EXPECT_FALSE(half_off.offer({turnedLoopAt(2, 0.1, 180 * deg, M_PI, kTrue)}).joined);
  off.min_new_view = 4.0;  // beyond pi
  EXPECT_NE(off.validate().find("min_new_view"), std::string::npos);
}

TEST(TrajectoryJoin, ALookAlikeNearlyAsWellSupportedHoldsTheFixBack) {
  TrajectoryJoin join;  // min_lead 2
  join.offer({loopAt(0, 0.0, kTrue), loopAt(0, 0.0, kLookAlike)});
  join.offer({loopAt(1, 1.0, kTrue), loopAt(1, 1.0, kLookAlike)});
  const llc::TrajectoryJoinResult three = join.offer({loopAt(2, 2.0, kTrue)});
  EXPECT_FALSE(three.joined);
  EXPECT_EQ(three.keyframes, 3u);
  EXPECT_EQ(three.rival_keyframes, 2u);
  EXPECT_NE(three.why_not.find("another place"), std::string::npos) << three.why_not;
  const llc::TrajectoryJoinResult four = join.offer({loopAt(3, 3.0, kTrue)});
  ASSERT_TRUE(four.joined) << four.why_not;
  EXPECT_NEAR(four.map_from_trajectory.x, kTrue.x, 1e-9);  // the true place, not the look-alike
}

TEST(TrajectoryJoin, TwoPlacesEachWithEnoughSupportFixNeither) {
  // A corridor of like doors: the look-alike gathers three keyframes of its own, the other
  // place five. A lead of two is no proof when the rival alone would have been a fix.
  TrajectoryJoin join;  // min_keyframes 3, min_lead 2
  for (std::size_t k = 0; k < 3; ++k) join.offer({loopAt(k, double(k), kTrue), loopAt(k, double(k), kLookAlike)});
  join.offer({loopAt(3, 3.0, kTrue)});
  const llc::TrajectoryJoinResult five = join.offer({loopAt(4, 4.0, kTrue)});
  EXPECT_FALSE(five.joined);
  EXPECT_EQ(five.keyframes, 5u);
  EXPECT_EQ(five.rival_keyframes, 3u);
  EXPECT_NE(five.why_not.find("enough for a fix of its own"), std::string::npos) << five.why_not;
  // Once the look-alike's loops leave the window (30 m of path), the place is told apart.
  for (std::size_t k = 5; k < 40; ++k) join.offer({loopAt(k, double(k), kTrue)});
  const llc::TrajectoryJoinResult later = join.offer({loopAt(40, 40.0, kTrue)});
  ASSERT_TRUE(later.joined) << later.why_not;
  EXPECT_EQ(later.rival_keyframes, 0u);
  EXPECT_NEAR(later.map_from_trajectory.x, kTrue.x, 1e-9);
}

TEST(TrajectoryJoin, ToleranceGrowsWithThePathBetweenTwoKeyframes) {
  const TrajectoryJoin join;  // 0.5 m + 0.02 m per m of path
  const JoinHypothesis a = loopAt(0, 0.0, kTrue);
  const Pose2 miss{0.6, 0.0, 0.0};
  EXPECT_FALSE(join.agree(a, loopAt(1, 1.0, kTrue, miss)));   // 0.52 m allowed
  EXPECT_TRUE(join.agree(a, loopAt(1, 10.0, kTrue, miss)));   // 0.70 m allowed
  EXPECT_FALSE(join.agree(a, loopAt(1, 10.0, kTrue, Pose2{0.0, 0.0, 0.15})));  // 0.13 rad allowed
}

TEST(TrajectoryJoin, ALiveMapsOwnUncertaintyWidensTheToleranceBetweenItsKeyframes) {
  // Two loops into map keyframes 3 and 40 whose frames differ by 2 m: more than the 0.5 m (+ 0.02
  // m per m of path) a map taken as exact allows, within a bent map's 3 m between those two.
  std::size_t asked = 0;
  const llc::MapAllowanceOf allowance = [&asked](std::size_t a, std::size_t b) {
    ++asked;
    EXPECT_EQ(a, 3u);  // the pair, smaller keyframe first
    EXPECT_EQ(b, 40u);
    return llc::MapAllowance{3.0, 0.05};
  };
  const TrajectoryJoin exact;
  const TrajectoryJoin live({}, allowance, 3.0);
  JoinHypothesis a = loopAt(0, 0.0, kTrue), b = loopAt(1, 1.0, kTrue, Pose2{2.0, 0.0, 0.0});
  a.map_keyframe = 40, b.map_keyframe = 3;
  EXPECT_FALSE(exact.agree(a, b));
  EXPECT_FALSE(live.agree(a, b));  // the keyframes' own bounds (0 m) cannot reach 2 m: not asked
  EXPECT_EQ(asked, 0u);
  a.map_std = 0.4, b.map_std = 0.4;  // 3 x 0.8 m could: asked
  EXPECT_TRUE(live.agree(a, b));
  EXPECT_TRUE(live.agree(b, a));
  EXPECT_EQ(asked, 1u);  // kept for the rest of the offer
  b.map_pose.theta += 0.2;  // a turn beyond 0.1 + 0.05 rad
  EXPECT_FALSE(live.agree(a, b));
  b = loopAt(1, 1.0, kTrue, Pose2{4.0, 0.0, 0.0});
  b.map_keyframe = 3, b.map_std = 0.4;
  EXPECT_FALSE(live.agree(a, b));  // 4 m: beyond even the bound, not asked
  EXPECT_EQ(asked, 1u);
  b.map_keyframe = 40;  // into the same keyframe: no room for the map's error
  b.map_pose = loopAt(1, 1.0, kTrue, Pose2{2.0, 0.0, 0.0}).map_pose;
  EXPECT_FALSE(live.agree(a, b));
}

TEST(TrajectoryJoin, LoopsOutOfTheWindowAreForgottenAndBadOnesIgnored) {
  TrajectoryJoin join;  // window 30 m
  join.offer({loopAt(0, 0.0, kTrue)});
  join.offer({loopAt(1, 1.0, kTrue)});
  JoinHypothesis bad = loopAt(2, 2.0, kTrue);
  bad.map_pose.x = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(join.offer({bad}).joined);
  EXPECT_EQ(join.hypotheses().size(), 2u);
  const llc::TrajectoryJoinResult r = join.offer({loopAt(3, 40.0, kTrue)});
  EXPECT_FALSE(r.joined);
  EXPECT_EQ(join.hypotheses().size(), 1u);
}

llc::ScanSequence straightSequence(std::size_t n) {
  llc::ScanSequence s;
  for (std::size_t i = 0; i < n; ++i) {
    llc::LoggedScan scan;
    scan.truth = {double(i), 0.0, 0.0};
    scan.odometry = {double(i), 0.0, 0.0};
    scan.stamp = 0.1 * double(i);
    scan.scan.stamp = scan.stamp;
    s.scans.push_back(scan);
  }
  return s;
}

TEST(Kidnapped, OdometryAndStampsRunOnWhileTheTruthJumps) {
  const llc::ScanSequence moved = llc::kidnapped(straightSequence(10), 6, 2);
  ASSERT_EQ(moved.scans.size(), 6u + 8u);
  EXPECT_DOUBLE_EQ(moved.scans[5].odometry.x, 5.0);
  EXPECT_DOUBLE_EQ(moved.scans[6].truth.x, 2.0);     // carried back to scan 2's place
  EXPECT_DOUBLE_EQ(moved.scans[6].odometry.x, 6.0);  // one recorded step on from scan 5's reading
  EXPECT_DOUBLE_EQ(moved.scans[13].odometry.x, 13.0);
  EXPECT_NEAR(moved.scans[6].stamp, 0.6, 1e-12);
  EXPECT_NEAR(moved.scans[6].scan.stamp, 0.6, 1e-12);
  EXPECT_THROW(llc::kidnapped(straightSequence(10), 0, 2), std::invalid_argument);
  EXPECT_THROW(llc::kidnapped(straightSequence(10), 3, 10), std::invalid_argument);
}

TEST(Kidnapped, ASimulatedDriveIsCarriedAwayTheSameWay) {
  llc::SimDrive drive;
  for (std::size_t i = 0; i < 10; ++i) {
    llc::SimFrame frame;
    frame.truth = {double(i), 0.0, 0.0};
    frame.odometry = {double(i), 1.0, 0.5};  // odometry in a frame of its own, turned
    frame.stamp = 0.1 * double(i);
    frame.front = {double(i)};
    drive.frames.push_back(frame);
  }
  const llc::SimDrive moved = llc::kidnapped(drive, 6, 2);
  ASSERT_EQ(moved.frames.size(), 6u + 8u);
  EXPECT_DOUBLE_EQ(moved.frames[6].truth.x, 2.0);
  EXPECT_DOUBLE_EQ(moved.frames[6].front[0], 2.0);  // its scan is where it was put
  EXPECT_NEAR(moved.frames[6].odometry.x, 6.0, 1e-12);
  EXPECT_NEAR(moved.frames[6].odometry.y, 1.0, 1e-12);
  EXPECT_NEAR(moved.frames[13].odometry.x, 13.0, 1e-12);
  EXPECT_NEAR(moved.frames[13].stamp, 1.3, 1e-12);
  EXPECT_THROW(llc::kidnapped(drive, 6, 0), std::invalid_argument);
  EXPECT_THROW(llc::kidnapped(llc::SimDrive{}, 1, 1), std::invalid_argument);
}

TEST(StartsNearMap, AStartCountsWhenItsFirstMetresPassTheMap) {
  std::vector<Pose2> truth;
  for (int i = 0; i <= 20; ++i) truth.push_back({double(i), 0.0, 0.0});
  // Within 1 m of (15, 0.5): x in [14.13, 15.87], scan 15 alone; reached within 10 m from 5 .. 15.
  const std::vector<bool> starts = llc::startsNearMap(truth, {{15.0, 0.5, 0.0}}, 10.0, 1.0);
  for (int i = 0; i <= 20; ++i) EXPECT_EQ(starts[std::size_t(i)], i >= 5 && i <= 15) << "scan " << i;
  EXPECT_EQ(llc::startsNearMap(truth, {}, 10.0, 1.0), std::vector<bool>(21, false));
  // The map drove there the other way round: near, but not heading as the map did (45 degrees).
  EXPECT_EQ(llc::startsNearMap(truth, {{15.0, 0.5, M_PI}}, 10.0, 1.0), starts);
  EXPECT_EQ(llc::startsNearMap(truth, {{15.0, 0.5, M_PI}}, 10.0, 1.0, M_PI / 4), std::vector<bool>(21, false));
  EXPECT_EQ(llc::startsNearMap(truth, {{15.0, 0.5, -0.7}}, 10.0, 1.0, M_PI / 4), starts);  // 40 degrees off
}

TEST(ScoreLocalization, AgainstWhereTheMapHasThePlaceAndAgainstTheTruth) {
  // Two map keyframes; the second sits 0.5 m off its truth in the map (the map bends there).
  llc::MapWithTruth map;
  map.truth = {{0.0, 0.0, 0.0}, {10.0, 0.0, 0.0}};
  map.poses = {{0.0, 0.0, 0.0}, {10.0, 0.5, 0.0}};
  map.truth_from_map = {};  // taken as the identity
  std::vector<llc::LocalizedScan> scans(4);
  scans[0] = {true, true, {1.0, 0.0, 0.0}, {1.0, 0.0, 0.0}};    // exact, near keyframe 0
  scans[1] = {true, false, {9.0, 0.5, 0.0}, {9.0, 0.0, 0.0}};   // where the map has it (near keyframe 1)
  scans[2] = {false, false, {}, {3.0, 0.0, 0.0}};               // lost: not scored
  scans[3] = {true, true, {9.0, 2.5, 0.0}, {9.0, 0.0, 0.0}};    // 2 m off the map's place: wrong
  const llc::LocalizationScore s = llc::scoreLocalization(scans, map, 1.0, 0.1);
  EXPECT_EQ(s.localized, 3u);
  EXPECT_EQ(s.fixes, 2u);
  EXPECT_EQ(s.wrong_fixes, 1u);
  EXPECT_EQ(s.wrong_poses, 1u);
  EXPECT_NEAR(s.rms_m, std::sqrt(4.0 / 3.0), 1e-12);
  EXPECT_NEAR(s.max_m, 2.0, 1e-12);
  // Against the truth: scan 1 is 0.5 m off (the map's bending), scan 3 2.5 m.
  EXPECT_EQ(s.wrong_fixes_global, 1u);
  EXPECT_NEAR(s.rms_global_m, std::sqrt((0.25 + 6.25) / 3.0), 1e-12);
  EXPECT_EQ(s.beyond_map, 0u);
  // Judged within 1.5 m of a map keyframe only: scans 1 and 3 (1 m from keyframe 1) still are,
  // one 30 m from both is counted apart.
  scans.push_back({true, false, {40.0, 9.0, 0.0}, {40.0, 0.0, 0.0}});
  const llc::LocalizationScore near = llc::scoreLocalization(scans, map, 1.0, 0.1, 1.5);
  EXPECT_EQ(near.localized, 3u);
  EXPECT_EQ(near.beyond_map, 1u);
  EXPECT_EQ(near.wrong_poses, 1u);
  EXPECT_EQ(llc::scoreLocalization(scans, map, 1.0, 0.1).wrong_poses, 2u);  // judged when not bounded
  // A scan whose reference its own scans contradict is counted apart among the wrong ones
  // only: marked on a right pose (scan 1), it counts nowhere.
  EXPECT_EQ(near.wrong_fixes_contradicted, 0u);
  scans[3].reference_contradicted = true, scans[1].reference_contradicted = true;
  const llc::LocalizationScore marked = llc::scoreLocalization(scans, map, 1.0, 0.1, 1.5);
  EXPECT_EQ(marked.wrong_fixes, 1u);  // still wrong by the reference
  EXPECT_EQ(marked.wrong_fixes_contradicted, 1u);
  EXPECT_EQ(marked.wrong_poses_contradicted, 1u);
  // One scan's error as the score sees it: scan 3 is 2 m off the map's place (wrong), scan 1 is
  // right; an error that is not finite is wrong.
  EXPECT_NEAR(llc::scanError(scans[3], map).against_map.y, 2.0, 1e-12);
  EXPECT_TRUE(llc::wrongPose(llc::scanError(scans[3], map).against_map, 1.0, 0.1));
  EXPECT_FALSE(llc::wrongPose(llc::scanError(scans[1], map).against_map, 1.0, 0.1));
  EXPECT_TRUE(llc::wrongPose({std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0}, 1.0, 0.1));
}

}  // namespace
