// A reference pose contradicted by its own scans: scans of an irregular room, the middle
// one's reference turned by 10 degrees (as csail's scans 397-399 are in its corrected log).
#include <gtest/gtest.h>

#include <cmath>

#include "laser_loop_closure/core/slam/reference_check.hpp"
#include "../synthetic_room.hpp"

namespace {

using llc::Pose2;

/// Five scans along a drive through the room; check(k, truths) checks scan k against the two
/// nearest on either side (as many as there are).
struct FiveScans {
  llc::ScanAligner aligner;
  std::vector<std::shared_ptr<const llc::PreparedScan>> scans;
  std::vector<Pose2> poses = {{-2.0, -0.2, 0.0}, {-1.0, 0.0, 0.1}, {0.0, 0.2, 0.3}, {1.0, 0.3, 0.4}, {2.0, 0.2, 0.5}};
  FiveScans() {
    const auto walls = llc_test::room();
    for (std::size_t k = 0; k < poses.size(); ++k) scans.push_back(aligner.prepare(llc_test::scanAt(walls, poses[k], 720, 0.005, k + 1)));
  }
  llc::ReferenceCheck check(std::size_t k, const std::vector<Pose2>& truth, const llc::ReferenceCheckOptions& options = {}) const {
    std::vector<llc::ReferenceNeighbour> before, after;
    for (std::size_t j = k; j-- > 0 && k - j <= 2;) before.push_back({scans[j].get(), truth[j]});
    for (std::size_t j = k + 1; j < scans.size() && j - k <= 2; ++j) after.push_back({scans[j].get(), truth[j]});
    return llc::checkReferencePose(aligner, *scans[k], truth[k], before, after, options);
  }
};

Pose2 turned(Pose2 p) {
  p.theta += 10.0 * M_PI / 180.0;
  return p;
}

TEST(ReferenceCheck, APoseTurnedAgainstBothSidesIsContradicted) {
  const FiveScans s;
  // The true poses: nothing to contradict.
  const llc::ReferenceCheck right = s.check(2, s.poses);
  EXPECT_FALSE(right.contradicted);
  EXPECT_LT(right.before.turn, 0.01);
  EXPECT_LT(right.after.turn, 0.01);
  // The middle reference turned by 10 degrees: ICP turns it back on both sides and fits better.
  std::vector<Pose2> glitch = s.poses;
  glitch[2] = turned(glitch[2]);
  const llc::ReferenceCheck found = s.check(2, glitch);
  EXPECT_TRUE(found.contradicted);
  EXPECT_NEAR(found.before.turn, 10.0 * M_PI / 180.0, 0.01);
  EXPECT_NEAR(found.after.turn, 10.0 * M_PI / 180.0, 0.01);
  EXPECT_GE(found.before.fit_gain, 0.1);
  // A glitch of two scans (1 and 2): scan 2 agrees with scan 1, but not with scan 0 beyond it.
  glitch[1] = turned(glitch[1]);
  EXPECT_TRUE(s.check(2, glitch).contradicted);
  // A glitch of neighbours on one side only makes that side disagree: scan 2 is not blamed.
  std::vector<Pose2> neighbours = s.poses;
  neighbours[3] = turned(neighbours[3]), neighbours[4] = turned(neighbours[4]);
  const llc::ReferenceCheck one_side = s.check(2, neighbours);
  EXPECT_FALSE(one_side.before.contradicts);
  EXPECT_TRUE(one_side.after.contradicts);
  EXPECT_FALSE(one_side.contradicted);
  // A turn below min_turn is no contradiction, however the fit compares; no neighbour on a
  // side (the first scan) is none either.
  llc::ReferenceCheckOptions strict;
  strict.min_turn = 0.5;
  EXPECT_FALSE(s.check(2, glitch, strict).contradicted);
  std::vector<Pose2> first = s.poses;
  first[0] = turned(first[0]);
  EXPECT_FALSE(s.check(0, first).contradicted);
}

TEST(ReferenceCheck, NeighboursAreSpacedAsKeyframesAndStopAtAJump) {
  // A drive along x in steps of 0.4 m, a turn on the spot at scan 6 (0.5 rad), then a jump of
  // 20 m (a kidnapping) after scan 9.
  std::vector<Pose2> truth;
  for (int k = 0; k <= 5; ++k) truth.push_back({0.4 * k, 0.0, 0.0});
  truth.push_back({2.0, 0.0, 0.5});
  for (int k = 7; k <= 9; ++k) truth.push_back({2.0 + 0.4 * (k - 6), 0.0, 0.5});
  truth.push_back({22.0, 0.0, 0.5});
  const llc::ReferenceNeighbourIndices at5 = llc::referenceNeighbourIndices(truth, 5, 1.0, 0.35, 3, 5.0);
  // Back from scan 5 (at 2.0 m): 1.6 and 1.2 m are within 1 m of it, 0.8 m is not (taken), and
  // 0.4 and 0 m are within 1 m of that.
  EXPECT_EQ(at5.before, (std::vector<std::size_t>{2}));
  // Forward: scan 6 turned 0.5 rad (taken), 8 is 0.8 m from 6 with the same heading: no; 9 is
  // 1.2 m (taken); 10 lies 20 m away: the walk ends there.
  EXPECT_EQ(at5.after, (std::vector<std::size_t>{6, 9}));
  // At most `count` a side; none before the first scan; an index past the end gives nothing.
  EXPECT_EQ(llc::referenceNeighbourIndices(truth, 9, 0.3, 0.35, 2, 5.0).before, (std::vector<std::size_t>{8, 7}));
  EXPECT_TRUE(llc::referenceNeighbourIndices(truth, 0).before.empty());
  EXPECT_TRUE(llc::referenceNeighbourIndices(truth, 99).after.empty());
}

}  // namespace
