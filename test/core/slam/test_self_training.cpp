// Self-training's one decision (core/slam/self_training): which keyframes, which pairs, which
// gap, for the train_classifier service (through the front end) and `llc train --from-session`.
#include <gtest/gtest.h>

#include <cmath>

#include "laser_loop_closure/core/sim/sim_drive.hpp"
#include "laser_loop_closure/core/slam/self_training.hpp"
#include "laser_loop_closure/core/slam/slam_front_end.hpp"
#include "../test_util.hpp"

namespace {

constexpr llc::FeatureSet kSet = llc::FeatureSet::kPaper;

/// 40 keyframes standing, 30 m out at heading 0 and back at heading pi: the way back meets
/// the way out facing the other way.
std::vector<llc::Pose2> outAndBack() {
  std::vector<llc::Pose2> poses;
  for (int k = 0; k < 40; ++k) poses.push_back({0.0, 0.0, 0.0});
  for (int k = 1; k <= 30; ++k) poses.push_back({double(k), 0.0, 0.0});
  for (int k = 29; k >= 0; --k) poses.push_back({double(k), 0.0, M_PI});
  return poses;
}

std::vector<std::vector<double>> distinctFeatures(std::size_t count) {
  std::vector<std::vector<double>> features(count);
  for (std::size_t k = 0; k < count; ++k) features[k] = std::vector<double>(llc::featureCount(kSet), double(k));
  return features;
}

TEST(SelfTraining, LabelsOnlyTheKeyframesTheBackEndHasPlaced) {
  const std::vector<llc::Pose2> poses = outAndBack();
  const std::vector<std::vector<double>> features = distinctFeatures(poses.size() + 5);  // 5 not placed yet
  const llc::SelfTrainingSet own = llc::selfTrainingSet(features, poses, kSet, true, 30);
  EXPECT_EQ(own.keyframes, poses.size());
  ASSERT_EQ(own.set.size(), own.pairs.size());
  ASSERT_GT(own.positives(), 0u);
  for (const llc::LabeledPair& p : own.pairs) {
    EXPECT_LT(std::max(p.a, p.b), poses.size());
    if (p.label == 1) {
      EXPECT_GE(p.b - p.a, 30u) << "a positive closer than the gap";
    }
  }
  EXPECT_NE(own.summary().find(std::to_string(poses.size()) + " keyframes, " + std::to_string(own.positives()) +
                               " positive and "),
            std::string::npos)
      << own.summary();
  // Fewer features than poses: the same rule the other way round.
  EXPECT_EQ(llc::selfTrainingSet(distinctFeatures(50), poses, kSet, true, 30).keyframes, 50u);
}

TEST(SelfTraining, RefusesFeaturesOfAnotherSet) {
  const std::vector<llc::Pose2> poses = outAndBack();
  std::vector<std::vector<double>> features = distinctFeatures(poses.size());
  features[7].resize(llc::featureCount(llc::FeatureSet::kExtended));
  try {
    llc::selfTrainingSet(features, poses, kSet, true, 30);
    FAIL() << "keyframe 7 has extended features";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("keyframe 7"), std::string::npos) << e.what();
  }
}

TEST(SelfTraining, ASessionOfPartialScansNeverPairsTheWayBackWithTheWayOut) {
  llc::SlamSession session;
  session.poses = outAndBack();
  session.features = distinctFeatures(session.poses.size());
  session.keyframes.resize(session.poses.size());
  auto facingAway = [&](const llc::SelfTrainingSet& own) {
    std::size_t count = 0;
    for (const llc::LabeledPair& p : own.pairs)
      count += p.label == 1 && std::abs(session.poses[p.b].theta - session.poses[p.a].theta) > M_PI / 2;
    return count;
  };
  for (llc::Keyframe& k : session.keyframes) k.scan.full_circle = true;
  EXPECT_GT(facingAway(llc::selfTrainingSet(session, kSet, 30)), 0u) << "360-degree scans: any heading is a revisit";
  session.keyframes[3].scan.full_circle = false;  // one partial scan makes it a partial session
  EXPECT_FALSE(llc::allFullCircle(session.keyframes));
  EXPECT_EQ(facingAway(llc::selfTrainingSet(session, kSet, 30)), 0u);
}

TEST(SelfTraining, TheFrontEndLabelsItsOwnKeyframesWithItsOwnGap) {
  llc::SimDriveOptions options;
  options.length_m = 60.0;
  const llc::SimDrive drive = llc::simulateDrive(llc::SimWorld(llc::simWorldOptions(options)), options);
  llc::LoopDetectorOptions loops;
  loops.min_keyframe_gap = 4;
  llc::SlamFrontEnd front(llc_test::defaultModel(), llc::ScanOdometryOptions{}, llc::ScanAlignerOptions{}, loops);
  for (const llc::SimFrame& frame : drive.frames) front.addScan(llc_test::frameScan(drive, frame), &frame.odometry);
  const std::size_t keyframes = front.keyframeCount();
  ASSERT_GT(keyframes, 20u);
  // Poses as a back end might place them (one keyframe behind): the second half of the
  // keyframes back over the first, 2 m apart, so that there are revisits and far pairs.
  std::vector<llc::Pose2> placed;
  for (std::size_t k = 0; k + 1 < keyframes; ++k)
    placed.push_back({2.0 * double(std::min(k, keyframes - 1 - k)), 0.0, 0.0});
  const llc::SelfTrainingSet own = front.selfTrainingSet(placed);
  EXPECT_EQ(own.keyframes, placed.size());
  ASSERT_FALSE(own.pairs.empty());
  ASSERT_EQ(own.set.dimension, llc::pairFeatureCount(llc::FeatureSet::kExtended));
  for (std::size_t row = 0; row < own.pairs.size(); ++row) {
    const llc::LabeledPair& p = own.pairs[row];
    if (p.label == 1) {
      EXPECT_GE(p.b - p.a, 4u);
    }
    // Each row is the pair features of the front end's own stored keyframe features.
    const std::vector<double> expected =
        llc::pairFeatures(llc::FeatureSet::kExtended, front.detector().features(p.a), front.detector().features(p.b));
    for (std::size_t i = 0; i < expected.size(); ++i) ASSERT_EQ(own.set.row(row)[i], expected[i]) << row << " " << i;
  }
}

}  // namespace
