// LoopConsensus alone (hand-worked cycles) and inside SlamBackEnd: a chain with one step slid
// 0.4 m too far, whose true loops the gate refuses one by one until four agree.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <vector>

#include "laser_loop_closure/core/slam/loop_consensus.hpp"
#include "laser_loop_closure/core/slam/session_io.hpp"
#include "laser_loop_closure/core/slam/slam_back_end.hpp"

namespace {

using llc::LoopClosure;
using llc::LoopConsensus;
using llc::LoopConsensusOptions;
using llc::Pose2;

LoopClosure loopOf(std::size_t from, std::size_t to, Pose2 pose) {
  LoopClosure loop;
  loop.from = from, loop.to = to, loop.pose = pose, loop.accepted = true;
  loop.covariance = Eigen::Vector3d(0.05 * 0.05, 0.05 * 0.05, 0.01 * 0.01).asDiagonal();
  return loop;
}

/// Keyframe k at (k, 0, 0): what the map says.
std::vector<Pose2> straightLine(std::size_t n) {
  std::vector<Pose2> poses;
  for (std::size_t k = 0; k < n; ++k) poses.push_back({double(k), 0.0, 0.0});
  return poses;
}

TEST(LoopConsensus, OptionsAreValidated) {
  EXPECT_TRUE(LoopConsensusOptions{}.validate().empty());
  LoopConsensusOptions o;
  o.min_loops = 1;
  EXPECT_NE(o.validate().find("min_loops"), std::string::npos);
  o = {}, o.min_loops = 0;  // off
  EXPECT_TRUE(o.validate().empty());
  o = {}, o.max_chi2 = 0.0;
  EXPECT_NE(o.validate().find("max_chi2"), std::string::npos);
  o = {}, o.max_chi2 = std::nan("");
  EXPECT_NE(o.validate().find("max_chi2"), std::string::npos);
  o = {}, o.max_translation = -1.0;
  EXPECT_NE(o.validate().find("max_translation"), std::string::npos);
  o = {}, o.max_rotation = 4.0;
  EXPECT_NE(o.validate().find("max_rotation"), std::string::npos);
  o = {}, o.max_kept = 3;
  EXPECT_NE(o.validate().find("max_kept"), std::string::npos);
  EXPECT_THROW(LoopConsensus{o}, std::invalid_argument);
}

TEST(LoopConsensus, TwoLoopsAgreeWhenTheCycleThroughTheMapBetweenTheirEndsCloses) {
  const LoopConsensus consensus;
  const std::vector<Pose2> map = straightLine(60);
  // Both say the newer end lies 1 m ahead of the older (the map says 10): the map between
  // their ends (1 m on either side) closes the cycle exactly.
  const LoopClosure a = loopOf(0, 10, {1.0, 0.0, 0.0});
  EXPECT_TRUE(consensus.agree(a, loopOf(1, 11, {1.0, 0.0, 0.0}), map));
  EXPECT_TRUE(consensus.agree(a, loopOf(3, 10, {-2.0, 0.0, 0.0}), map));  // from 3 m on, 2 m back: 1 m
  EXPECT_FALSE(consensus.agree(a, loopOf(3, 10, {-1.0, 0.0, 0.0}), map));
  EXPECT_TRUE(consensus.agree(a, loopOf(0, 10, {1.25, 0.0, 0.0}), map));  // 0.25 m: within 0.3
  EXPECT_FALSE(consensus.agree(a, loopOf(0, 10, {1.35, 0.0, 0.0}), map));
  EXPECT_TRUE(consensus.agree(a, loopOf(0, 10, {1.0, 0.0, 0.04}), map));
  EXPECT_FALSE(consensus.agree(a, loopOf(0, 10, {1.0, 0.0, 0.06}), map));
  // A turned loop: the cycle closes in place but not in heading.
  EXPECT_FALSE(consensus.agree(a, loopOf(1, 11, {1.0, 0.0, 0.5}), map));
  // Ends too far apart along the drive to trust the map between them (30 keyframes).
  EXPECT_FALSE(consensus.agree(a, loopOf(0, 41, {32.0, 0.0, 0.0}), map));
  EXPECT_TRUE(consensus.agree(a, loopOf(0, 40, {31.0, 0.0, 0.0}), map));
  // A keyframe the poses do not have.
  EXPECT_FALSE(consensus.agree(a, loopOf(0, 60, {1.0, 0.0, 0.0}), map));
}

TEST(LoopConsensus, AppliesAGroupOnceEnoughAgreeAndForgetsIt) {
  LoopConsensusOptions options;
  options.min_loops = 3;
  LoopConsensus consensus(options);
  const std::vector<Pose2> map = straightLine(40);
  EXPECT_TRUE(consensus.offer(7, loopOf(0, 10, {1.0, 0.0, 0.0}), 40.0, map).kept);
  // One that agrees with nothing kept waits too, and does not count.
  EXPECT_TRUE(consensus.offer(8, loopOf(0, 10, {3.0, 0.0, 0.0}), 40.0, map).kept);
  // Above max_chi2 (a mirror image): never kept; consensus off: nothing.
  EXPECT_FALSE(consensus.offer(9, loopOf(2, 12, {1.0, 0.0, 0.0}), 500.0, map).kept);
  EXPECT_FALSE(consensus.offer(9, loopOf(2, 12, {std::nan(""), 0.0, 0.0}), 40.0, map).kept);
  const llc::LoopConsensusResult second = consensus.offer(10, loopOf(1, 11, {1.0, 0.0, 0.0}), 30.0, map);
  EXPECT_TRUE(second.kept);
  EXPECT_TRUE(second.group.empty());
  EXPECT_EQ(consensus.kept(), 3u);
  const llc::LoopConsensusResult third = consensus.offer(11, loopOf(2, 12, {1.0, 0.0, 0.0}), 20.0, map);
  EXPECT_FALSE(third.kept);
  EXPECT_EQ(third.group, (std::vector<std::size_t>{7, 10, 11}));  // the kept ones in order, the newest last
  EXPECT_EQ(consensus.kept(), 1u);  // the one that disagreed waits on
  options.min_loops = 0;
  LoopConsensus off(options);
  EXPECT_FALSE(off.offer(1, loopOf(0, 10, {1.0, 0.0, 0.0}), 20.0, map).kept);
  EXPECT_EQ(off.kept(), 0u);
}

TEST(LoopConsensus, KeepsAtMostMaxKeptForgettingTheOldest) {
  LoopConsensusOptions options;
  options.min_loops = 3, options.max_kept = 3;
  LoopConsensus consensus(options);
  const std::vector<Pose2> map = straightLine(40);
  // Two that agree, then three that agree with nothing: the first two are forgotten.
  consensus.offer(0, loopOf(0, 10, {1.0, 0.0, 0.0}), 20.0, map);
  consensus.offer(1, loopOf(1, 11, {1.0, 0.0, 0.0}), 20.0, map);
  for (std::size_t id = 2; id < 5; ++id) consensus.offer(id, loopOf(0, 10, {3.0 + double(id), 0.0, 0.0}), 20.0, map);
  EXPECT_EQ(consensus.kept(), 3u);
  EXPECT_TRUE(consensus.offer(5, loopOf(2, 12, {1.0, 0.0, 0.0}), 20.0, map).group.empty());
}

/// 21 keyframes 1 m apart along x; step 10 measured 1.4 m (slid 0.4 m too far), all certain
/// to 1 cm: a true loop over it misses the map by 0.4 m, chi-square about 40 (gate 16.27).
void slidChain(llc::SlamBackEnd& back) {
  const Eigen::Matrix3d step = Eigen::Vector3d(0.01 * 0.01, 0.01 * 0.01, 0.001 * 0.001).asDiagonal();
  for (int k = 0; k < 21; ++k) {
    llc::Keyframe keyframe;
    keyframe.stamp = k;
    back.addKeyframe(keyframe, Pose2{k == 10 ? 1.4 : 1.0, 0.0, 0.0}, step);
  }
}

TEST(LoopConsensus, TheBackEndAppliesTrueLoopsTheGateRefusedOnceFourAgree) {
  llc::SlamBackEnd back;
  slidChain(back);
  ASSERT_NEAR(back.poses()[15].x, 15.4, 1e-6);
  // True loops over the slid step: keyframe 15 + i is 15 m ahead of keyframe i.
  for (std::size_t i = 0; i < 3; ++i) {
    const llc::LoopRecord refused = back.addLoop(loopOf(i, 15 + i, {15.0, 0.0, 0.0}));
    EXPECT_FALSE(refused.applied);
    EXPECT_GT(refused.innovation_chi2, 16.27);
    EXPECT_LT(refused.innovation_chi2, 80.0);
    EXPECT_TRUE(back.lastConsensus().empty());
  }
  EXPECT_EQ(back.counters().refused_by_gate, 3u);
  // A wrong one (0.9 m off the others, chi-square about 62) waits too but agrees with none.
  EXPECT_FALSE(back.addLoop(loopOf(4, 19, {15.9, 0.0, 0.0})).applied);
  const llc::LoopRecord fourth = back.addLoop(loopOf(3, 18, {15.0, 0.0, 0.0}));
  EXPECT_TRUE(fourth.applied);
  EXPECT_TRUE(fourth.by_consensus);
  EXPECT_TRUE(fourth.reject_reason.empty());
  EXPECT_EQ(back.lastConsensus(), (std::vector<std::size_t>{0, 1, 2, 4}));
  for (std::size_t id : back.lastConsensus()) {
    EXPECT_TRUE(back.loops()[id].applied) << id;
    EXPECT_TRUE(back.loops()[id].by_consensus) << id;
  }
  EXPECT_FALSE(back.loops()[3].applied);  // the wrong one
  EXPECT_EQ(back.counters().loops_accepted, 4u);
  EXPECT_EQ(back.counters().applied_by_consensus, 4u);
  EXPECT_EQ(back.counters().refused_by_gate, 1u);
  // The map now holds the loops: keyframe 15 nearer 15 m than the chain's 15.4.
  EXPECT_LT(std::abs(back.poses()[15].x - back.poses()[0].x - 15.0), 0.2);
  // The next loop adds nothing by consensus.
  back.addLoop(loopOf(5, 20, {15.0, 0.0, 0.0}));
  EXPECT_TRUE(back.lastConsensus().empty());
}

TEST(LoopConsensus, OffOrWithoutTheGateTheBackEndAppliesNothingByConsensus) {
  LoopConsensusOptions off;
  off.min_loops = 0;
  llc::SlamBackEnd back({}, true, off);
  slidChain(back);
  for (std::size_t i = 0; i < 6; ++i) EXPECT_FALSE(back.addLoop(loopOf(i, 15 + i, {15.0, 0.0, 0.0})).applied);
  EXPECT_EQ(back.counters().applied_by_consensus, 0u);
  llc::SlamBackEnd ungated({}, false);
  slidChain(ungated);
  EXPECT_TRUE(ungated.addLoop(loopOf(0, 15, {15.0, 0.0, 0.0})).applied);
  EXPECT_FALSE(ungated.loops().back().by_consensus);
}

TEST(LoopConsensus, ARestoredSessionsRefusedLoopsWaitAgain) {
  llc::SlamBackEnd first;
  slidChain(first);
  for (std::size_t i = 0; i < 3; ++i) first.addLoop(loopOf(i, 15 + i, {15.0, 0.0, 0.0}));
  const llc::SlamSession session = llc::sessionOf(first, std::vector<std::vector<double>>(21));
  llc::SlamBackEnd second;
  ASSERT_EQ(second.restore(session), "");
  EXPECT_EQ(second.counters().refused_by_gate, 3u);
  EXPECT_TRUE(second.addLoop(loopOf(3, 18, {15.0, 0.0, 0.0})).applied);
  EXPECT_EQ(second.lastConsensus(), (std::vector<std::size_t>{0, 1, 2, 3}));
  EXPECT_EQ(second.counters().applied_by_consensus, 4u);
  // Saved again and restored: the four are applied, by consensus, and wait no more.
  const llc::SlamSession again = llc::sessionOf(second, std::vector<std::vector<double>>(21));
  llc::SlamBackEnd third;
  ASSERT_EQ(third.restore(again), "");
  EXPECT_EQ(third.counters().applied_by_consensus, 4u);
  EXPECT_EQ(third.counters().loops_accepted, 4u);
  EXPECT_EQ(third.counters().refused_by_gate, 0u);
  for (std::size_t id = 0; id < 4; ++id) EXPECT_TRUE(third.loops()[id].by_consensus) << id;
}

TEST(LoopConsensus, ARewordedReasonChangesNothingTheCodeDecides) {
  llc::SlamBackEnd first;
  slidChain(first);
  for (std::size_t i = 0; i < 3; ++i) first.addLoop(loopOf(i, 15 + i, {15.0, 0.0, 0.0}));
  llc::SlamSession session = llc::sessionOf(first, std::vector<std::vector<double>>(21, std::vector<double>(2, 0.0)));
  ASSERT_EQ(session.loops.size(), 3u);
  // Every gated loop's reason reworded (one to another stage's words), saved and loaded as a file.
  session.loops[0].reject_reason = "reworded";
  session.loops[1].reject_reason = "";
  session.loops[2].reject_reason = "validation: a stage that did not refuse it";
  const std::string path = ::testing::TempDir() + "reworded.llcsession";
  llc::saveSession(session, path);
  const llc::SlamSession loaded = llc::loadSession(path);
  for (const llc::LoopRecord& record : loaded.loops) EXPECT_EQ(record.refusal, llc::LoopRefusal::kBackEndGate) << record.reject_reason;
  llc::SlamBackEnd second;
  ASSERT_EQ(second.restore(loaded), "");
  EXPECT_TRUE(second.addLoop(loopOf(3, 18, {15.0, 0.0, 0.0})).applied);
  EXPECT_EQ(second.lastConsensus(), (std::vector<std::size_t>{0, 1, 2, 3}));
  // The other way round: the gate's words on loops whose code says validation refused them.
  session = llc::sessionOf(first, std::vector<std::vector<double>>(21, std::vector<double>(2, 0.0)));
  for (llc::LoopRecord& record : session.loops) record.refusal = llc::LoopRefusal::kValidation;
  llc::SlamBackEnd third;
  ASSERT_EQ(third.restore(session), "");
  EXPECT_FALSE(third.addLoop(loopOf(3, 18, {15.0, 0.0, 0.0})).applied);
  EXPECT_TRUE(third.lastConsensus().empty());
  std::remove(path.c_str());
}

}  // namespace
