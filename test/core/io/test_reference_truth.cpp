// Truth for a log from another log of the same drive (applyReferenceTruth): hand-worked poses.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "laser_loop_closure/core/io/reference_truth.hpp"

namespace {

using llc::Pose2;

/// A scan whose ranges say which one it is (value + 0.1 * beam), one beam without a return.
llc::LoggedScan scanWithRanges(double value, Pose2 odometry) {
  llc::LoggedScan s;
  for (int beam = 0; beam < 5; ++beam) {
    s.scan.bearings.push_back(-M_PI / 2 + beam * M_PI / 4);
    s.scan.ranges.push_back(beam == 4 ? INFINITY : value + 0.1 * beam);
  }
  s.odometry = s.truth = odometry;
  return s;
}

/// Five scans 1 m apart along the odometry's x axis; ranges 1.0, 2.0, ... 5.0.
llc::ScanSequence drive() {
  llc::ScanSequence sequence;
  sequence.source = "drive";
  for (int i = 0; i < 5; ++i) sequence.scans.push_back(scanWithRanges(1.0 + i, {double(i), 0.0, 0.0}));
  return sequence;
}

void expectPose(const Pose2& expected, const Pose2& actual) {
  EXPECT_NEAR(expected.x, actual.x, 1e-12);
  EXPECT_NEAR(expected.y, actual.y, 1e-12);
  EXPECT_NEAR(expected.theta, actual.theta, 1e-12);
}

TEST(ReferenceTruth, MatchedScansTakeTheReferencePoseAndTheRestAreCarriedByOdometry) {
  llc::ScanSequence sequence = drive();
  // The reference holds scans 1 and 3 (ranges within 1 cm), facing +y in its own frame, and
  // one scan of another place.
  llc::ScanSequence reference;
  reference.source = "reference";
  reference.scans.push_back(scanWithRanges(2.004, {10.0, 5.0, M_PI / 2}));
  reference.scans.push_back(scanWithRanges(9.0, {0.0, 0.0, 0.0}));
  reference.scans.push_back(scanWithRanges(3.996, {10.0, 7.0, M_PI / 2}));
  const llc::ReferenceTruthResult r = llc::applyReferenceTruth(reference, &sequence);
  EXPECT_EQ(r.matched, 2u);
  EXPECT_EQ(r.carried, 3u);
  EXPECT_EQ(r.ambiguous, 0u);
  EXPECT_EQ(r.max_carry_scans, 1u);
  EXPECT_EQ(r.matched_scans, (std::vector<bool>{false, true, false, true, false}));
  expectPose({10.0, 4.0, M_PI / 2}, sequence.scans[0].truth);  // 1 m behind scan 1, along +y
  expectPose({10.0, 5.0, M_PI / 2}, sequence.scans[1].truth);
  expectPose({10.0, 6.0, M_PI / 2}, sequence.scans[2].truth);  // between 1 and 3, whose carried poses agree
  expectPose({10.0, 7.0, M_PI / 2}, sequence.scans[3].truth);
  expectPose({10.0, 8.0, M_PI / 2}, sequence.scans[4].truth);
  expectPose({4.0, 0.0, 0.0}, sequence.scans[4].odometry);  // the odometry is left alone
  EXPECT_TRUE(std::isnan(r.gap_miss_m[4]));  // after the last matched scan: not known
  EXPECT_NEAR(r.gap_miss_m[2], 0.0, 1e-12);  // the odometry agrees with the reference
}

TEST(ReferenceTruth, AfterTheLastMatchedScanItsTurnedOdometryMotionIsComposed) {
  llc::ScanSequence sequence = drive();
  sequence.scans[3].odometry = {3.0, 0.0, 0.5};  // scan 3 turned in place by 0.5 rad
  sequence.scans[4].odometry = {3.0, 1.0, 0.5};  // then 1 m sideways (in the odometry frame)
  llc::ScanSequence reference;
  reference.scans.push_back(scanWithRanges(1.0, {0.0, 0.0, 0.0}));
  reference.scans.push_back(scanWithRanges(4.0, {3.0, 0.0, 0.5}));
  llc::applyReferenceTruth(reference, &sequence);
  // Scan 4 from scan 3: between((3,0,0.5), (3,1,0.5)) = (sin 0.5, cos 0.5, 0), composed on (3,0,0.5).
  const double c = std::cos(0.5), s = std::sin(0.5);
  const double dx = s, dy = c;
  expectPose({3.0 + c * dx - s * dy, s * dx + c * dy, 0.5}, sequence.scans[4].truth);
  expectPose({3.0, 1.0, 0.5}, sequence.scans[4].truth);  // the same, worked out
  expectPose({2.0, 0.0, 0.0}, sequence.scans[2].truth);  // from scan 0, two scans back
}

TEST(ReferenceTruth, BetweenTwoMatchedScansTheOdometrysErrorIsSpreadAlongTheGap) {
  llc::ScanSequence sequence = drive();  // odometry: scan 4 at (4, 0, 0)
  llc::ScanSequence reference;
  reference.scans.push_back(scanWithRanges(1.0, {0.0, 0.0, 0.0}));
  reference.scans.push_back(scanWithRanges(5.0, {5.0, 0.0, 0.2}));  // truly 1 m further, turned 0.2 rad
  const llc::ReferenceTruthResult r = llc::applyReferenceTruth(reference, &sequence);
  EXPECT_EQ(r.max_carry_scans, 2u);  // scan 2, two from either end
  // Carried from scan 0 to scan 4 the odometry reaches (4, 0, 0): 1 m from (5, 0, 0.2), 0.2 rad turned.
  EXPECT_NEAR(r.gap_miss_m[2], 1.0, 1e-12);
  EXPECT_NEAR(r.gap_miss_rad[1], 0.2, 1e-12);
  EXPECT_EQ(r.gap_miss_m[0], 0.0);  // matched
  EXPECT_EQ(r.gap_miss_rad[4], 0.0);
  // Scan 2 from scan 0: (2, 0, 0); from scan 4: (5, 0, 0.2) composed with (-2, 0, 0); half of each.
  expectPose({(2.0 + 5.0 - 2.0 * std::cos(0.2)) / 2.0, -std::sin(0.2), 0.1}, sequence.scans[2].truth);
  // Scan 1, a quarter of the way: 3/4 of (1, 0, 0) and 1/4 of (5 - 3 cos 0.2, -3 sin 0.2, 0.2).
  expectPose({0.75 + 0.25 * (5.0 - 3.0 * std::cos(0.2)), -0.75 * std::sin(0.2), 0.05}, sequence.scans[1].truth);
}

TEST(ReferenceTruth, RangesTwiceInEitherLogAreNotMatched) {
  llc::ScanSequence sequence = drive();
  sequence.scans[4] = scanWithRanges(4.0, {4.0, 0.0, 0.0});  // scans 3 and 4 look the same
  llc::ScanSequence reference;
  reference.scans.push_back(scanWithRanges(1.0, {0.0, 0.0, 0.0}));
  reference.scans.push_back(scanWithRanges(2.0, {1.0, 0.0, 0.0}));
  reference.scans.push_back(scanWithRanges(2.0, {1.5, 0.0, 0.0}));  // twice in the reference
  reference.scans.push_back(scanWithRanges(3.0, {2.0, 0.0, 0.0}));
  reference.scans.push_back(scanWithRanges(4.0, {9.0, 9.0, 0.0}));  // twice in the drive
  const llc::ReferenceTruthResult r = llc::applyReferenceTruth(reference, &sequence);
  EXPECT_EQ(r.matched, 2u);
  EXPECT_EQ(r.ambiguous, 3u);
  expectPose({1.0, 0.0, 0.0}, sequence.scans[1].truth);  // between scans 0 and 2
  expectPose({4.0, 0.0, 0.0}, sequence.scans[4].truth);  // carried from scan 2, not the 9, 9 pose
}

TEST(ReferenceTruth, AnotherDriveIsRefusedAndLeavesTheSequenceAlone) {
  llc::ScanSequence sequence = drive();
  llc::ScanSequence reference;
  reference.source = "elsewhere";
  reference.scans.push_back(scanWithRanges(1.05, {7.0, 7.0, 0.0}));  // 5 cm off: not the same scan
  reference.scans.push_back(scanWithRanges(2.0, {8.0, 8.0, 0.0}));   // one match is not enough
  EXPECT_THROW(llc::applyReferenceTruth(reference, &sequence), std::invalid_argument);
  for (int i = 0; i < 5; ++i) expectPose({double(i), 0.0, 0.0}, sequence.scans[std::size_t(i)].truth);
  llc::ScanSequence empty;
  EXPECT_THROW(llc::applyReferenceTruth(empty, &sequence), std::invalid_argument);
}

TEST(ReferenceTruth, AStalledOdometryReadingIsInterpolatedInTimeToCarryTheTruthBy) {
  // Scans 0.2 s apart, 1 m a scan; the odometry stalls at scan 1's reading over scans 2 and 3,
  // then catches up at scan 4 (4, 0, 0.3). Carried from the matched scans 0 and 5, scans 2
  // and 3 are where the time between scans 1 and 4 puts them, not at scan 1 and then a jump.
  llc::ScanSequence sequence = drive();
  sequence.scans.push_back(scanWithRanges(6.0, {5.0, 0.0, 0.3}));
  for (std::size_t i = 0; i < sequence.scans.size(); ++i) sequence.scans[i].stamp = 10.0 + 0.2 * double(i);
  sequence.scans[4].odometry = {4.0, 0.0, 0.3};
  sequence.scans[2].odometry = sequence.scans[3].odometry = sequence.scans[1].odometry;
  llc::ScanSequence reference;
  reference.scans.push_back(scanWithRanges(1.0, {0.0, 0.0, 0.0}));
  reference.scans.push_back(scanWithRanges(6.0, {5.0, 0.0, 0.3}));
  const llc::ReferenceTruthResult r = llc::applyReferenceTruth(reference, &sequence);
  EXPECT_EQ(r.stalled_odometry, 2u);
  // Scan 2 a third of the way from scan 1 (1, 0, 0) to scan 4 (3 m on, turned 0.3 rad): the
  // odometry agrees with the reference at both ends, so each carried pose is that one.
  expectPose({2.0, 0.0, 0.1}, sequence.scans[2].truth);
  expectPose({3.0, 0.0, 0.2}, sequence.scans[3].truth);
  EXPECT_NEAR(r.gap_miss_m[3], 0.0, 1e-12);
  expectPose({1.0, 0.0, 0.0}, sequence.scans[3].odometry);  // the odometry itself is left alone
  // A reading repeated for longer than 2 s is a robot that stood: carried as it is.
  llc::ScanSequence stood = drive();
  for (std::size_t i = 0; i < stood.scans.size(); ++i) stood.scans[i].stamp = 10.0 + 1.5 * double(i);
  stood.scans[2].odometry = stood.scans[1].odometry;
  stood.scans[3].odometry = {2.0, 0.0, 0.0};
  stood.scans[4].odometry = {3.0, 0.0, 0.0};
  reference.scans[1] = scanWithRanges(5.0, {3.0, 0.0, 0.0});
  EXPECT_EQ(llc::applyReferenceTruth(reference, &stood).stalled_odometry, 0u);
  expectPose({1.0, 0.0, 0.0}, stood.scans[2].truth);
}

}  // namespace
