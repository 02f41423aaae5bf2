// The relations metric (Kümmerle et al. 2009) on hand-worked tracks, and the .relations reader.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "laser_loop_closure/core/geometry/relation_error.hpp"
#include "laser_loop_closure/core/io/relations_io.hpp"
#include "../test_util.hpp"

namespace {

using llc::Pose2;

/// Four scans at stamps 10, 11, 12, 13 along x, each with its own pose and odometry = truth.
llc::ScanTrack straightTrack() {
  llc::ScanTrack track;
  for (int i = 0; i < 4; ++i) {
    track.stamps.push_back(10.0 + i);
    track.odometry.push_back({double(i), 0.0, 0.0});
    track.poses.push_back(Pose2{double(i), 0.0, 0.0});
  }
  return track;
}

TEST(RelationError, ExactPosesHaveNoError) {
  const llc::ScanTrack track = straightTrack();
  const llc::RelationErrorResult r = llc::evaluateRelations({{10.0, 12.0, {2.0, 0.0, 0.0}}, {11.0, 13.0, {2.0, 0.0, 0.0}}}, track);
  EXPECT_EQ(r.relations, 2u);
  EXPECT_EQ(r.evaluated, 2u);
  EXPECT_EQ(r.translation_mean, 0.0);
  EXPECT_EQ(r.rotation_mean, 0.0);
}

TEST(RelationError, HandWorkedMeansAndDeviations) {
  const llc::ScanTrack track = straightTrack();
  // Estimated 10 -> 11: (1, 0, 0). Against (1.1, 0, 0.1): 0.1 m, 0.1 rad; against
  // (1, 0.3, -0.3): 0.3 m, 0.3 rad. Mean 0.2, sample std sqrt((0.01 + 0.01) / 1) = 0.1414.
  const llc::RelationErrorResult r =
      llc::evaluateRelations({{10.0, 11.0, {1.1, 0.0, 0.1}}, {10.0, 11.0, {1.0, 0.3, -0.3}}}, track);
  ASSERT_EQ(r.evaluated, 2u);
  EXPECT_NEAR(r.errors[0].translation, 0.1, 1e-12);
  EXPECT_NEAR(r.errors[0].rotation, 0.1, 1e-12);
  EXPECT_NEAR(r.translation_mean, 0.2, 1e-12);
  EXPECT_NEAR(r.translation_std, std::sqrt(0.02), 1e-12);
  EXPECT_NEAR(r.rotation_mean, 0.2, 1e-12);
  EXPECT_NEAR(r.translation_max, 0.3, 1e-12);
  // The error is in the first scan's frame: turning the whole track changes nothing.
  llc::ScanTrack turned = track;
  for (auto& pose : turned.poses) *pose = llc::compose(Pose2{5.0, -2.0, 1.2}, *pose);
  const llc::RelationErrorResult t =
      llc::evaluateRelations({{10.0, 11.0, {1.1, 0.0, 0.1}}, {10.0, 11.0, {1.0, 0.3, -0.3}}}, turned);
  EXPECT_NEAR(t.translation_mean, 0.2, 1e-12);
  // A rotation error wraps: estimated pi - 0.05 against true -pi + 0.05 is 0.1 rad.
  llc::ScanTrack wrap = track;
  wrap.poses[1] = Pose2{1.0, 0.0, M_PI - 0.05};
  EXPECT_NEAR(llc::evaluateRelations({{10.0, 11.0, {1.0, 0.0, -M_PI + 0.05}}}, wrap).rotation_mean, 0.1, 1e-12);
}

TEST(RelationError, AScanWithoutPoseIsCarriedByOdometryFromTheNearestPlacedScan) {
  llc::ScanTrack track = straightTrack();
  // Scan 2 has no pose; the raw odometry puts it 0.5 m short of where scan 1's pose and the
  // truth would (its odometry drifts); scan 1 is nearest (before scan 3 at a tie).
  track.poses[2].reset();
  track.odometry[2] = {1.5, 0.0, 0.0};
  const llc::RelationErrorResult r = llc::evaluateRelations({{11.0, 12.0, {1.0, 0.0, 0.0}}, {10.0, 13.0, {3.0, 0.0, 0.0}}}, track);
  ASSERT_EQ(r.evaluated, 2u);
  EXPECT_EQ(r.carried, 1u);
  EXPECT_TRUE(r.errors[0].carried);
  EXPECT_NEAR(r.errors[0].translation, 0.5, 1e-12);  // carried from scan 1 by 0.5 m of odometry
  EXPECT_FALSE(r.errors[1].carried);
  EXPECT_NEAR(r.errors[1].translation, 0.0, 1e-12);
  // No pose anywhere: nothing evaluated, nothing thrown.
  for (auto& pose : track.poses) pose.reset();
  EXPECT_EQ(llc::evaluateRelations({{11.0, 12.0, {1.0, 0.0, 0.0}}}, track).evaluated, 0u);
}

TEST(RelationError, StampsOutOfOrderAndUnmatchedStamps) {
  llc::ScanTrack track = straightTrack();
  std::swap(track.stamps[1], track.stamps[2]);  // a log whose stamps are not sorted
  std::swap(track.odometry[1], track.odometry[2]);
  std::swap(track.poses[1], track.poses[2]);
  const llc::RelationErrorResult r =
      llc::evaluateRelations({{11.00005, 12.0, {1.0, 0.0, 0.0}}, {10.0, 17.0, {1.0, 0.0, 0.0}}}, track);
  EXPECT_EQ(r.evaluated, 1u);
  EXPECT_EQ(r.unmatched, 1u);
  EXPECT_EQ(r.errors[0].scan1, 2u);  // stamp 11 is the third line of this log
  EXPECT_NEAR(r.translation_mean, 0.0, 1e-12);
  track.poses.pop_back();
  EXPECT_THROW(llc::evaluateRelations({}, track), std::invalid_argument);
}

TEST(RelationError, TheMotionComparedIsTheScannersWhenItIsMountedOffTheBase) {
  // The base turns in place by 90 degrees; a scanner 0.04 m ahead of it swings from (0.04, 0)
  // to (0, 0.04): in the scanner's first frame it moved by (-0.04, 0.04) and turned 90 degrees.
  llc::ScanTrack track;
  track.stamps = {10.0, 11.0};
  track.odometry = {Pose2{}, Pose2{0.0, 0.0, M_PI / 2}};
  track.poses = {Pose2{}, Pose2{0.0, 0.0, M_PI / 2}};
  const std::vector<llc::Relation> scanner_relation{{10.0, 11.0, {-0.04, 0.04, M_PI / 2}}};
  EXPECT_NEAR(llc::evaluateRelations(scanner_relation, track).translation_mean, 0.04 * std::sqrt(2.0), 1e-12)
      << "the base's motion against the scanner's relation";
  track.scanner_mounts = {Pose2{0.04, 0.0, 0.0}, Pose2{0.04, 0.0, 0.0}};
  const llc::RelationErrorResult r = llc::evaluateRelations(scanner_relation, track);
  ASSERT_EQ(r.evaluated, 1u);
  EXPECT_NEAR(r.translation_mean, 0.0, 1e-12);
  EXPECT_NEAR(r.rotation_mean, 0.0, 1e-12);
  // A straight drive is the same for the base and a scanner on its axis.
  llc::ScanTrack straight = straightTrack();
  straight.scanner_mounts.assign(4, Pose2{0.04, 0.0, 0.0});
  EXPECT_NEAR(llc::evaluateRelations({{10.0, 13.0, {3.0, 0.0, 0.0}}}, straight).translation_mean, 0.0, 1e-12);
  // A carried end is carried in the base frame, then mounted: scan 1 carried from scan 0.
  track.poses[1].reset();
  EXPECT_NEAR(llc::evaluateRelations(scanner_relation, track).translation_mean, 0.0, 1e-12);
  track.scanner_mounts.pop_back();
  EXPECT_THROW(llc::evaluateRelations(scanner_relation, track), std::invalid_argument);
}

TEST(RelationsFile, ReadsRelationsAndRefusesBadLinesByNumber) {
  llc_test::TempDir dir;
  const std::string good = dir.path() + "/good.relations";
  std::ofstream(good) << "# comment\n90.2 90.7 0.42 -0.0007 0 0 0 0.017\n\n91.0 92.5 1 2 0 0 0 -0.4\n";
  const std::vector<llc::Relation> relations = llc::loadRelations(good);
  ASSERT_EQ(relations.size(), 2u);
  EXPECT_DOUBLE_EQ(relations[0].t1, 90.2);
  EXPECT_DOUBLE_EQ(relations[0].motion.x, 0.42);
  EXPECT_DOUBLE_EQ(relations[0].motion.theta, 0.017);
  EXPECT_DOUBLE_EQ(relations[1].motion.y, 2.0);
  auto refusal = [&](const std::string& text) {
    const std::string path = dir.path() + "/bad.relations";
    std::ofstream(path) << text;
    try {
      llc::loadRelations(path);
    } catch (const llc::RelationsError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(refusal("1 2 3 4 5 6 7 8\n1 2 3\n").find("bad.relations:2: 3 values"), std::string::npos);
  EXPECT_NE(refusal("1 2 3 4 5 6 7 nan\n").find("bad.relations:1: 'nan' is not a finite number"), std::string::npos);
  EXPECT_NE(refusal("1 2 3 4x 5 6 7 8\n").find("'4x'"), std::string::npos);
  EXPECT_NE(refusal("# nothing\n").find("no relation"), std::string::npos);
  EXPECT_NE(refusal("1 2 3 4 5 6 7 8\n9 10 11 12 13 14 15 16").find("no error"), std::string::npos) << "no final newline is fine";
  EXPECT_THROW(llc::loadRelations(dir.path() + "/missing.relations"), llc::RelationsError);
}

}  // namespace
