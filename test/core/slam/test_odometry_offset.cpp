// Odometry out of step with the scans: shifting it, and finding the shift from the scans.
#include <gtest/gtest.h>

#include <limits>
#include <stdexcept>

#include "laser_loop_closure/core/slam/odometry_offset.hpp"
#include "laser_loop_closure/core/sim/sim_drive.hpp"
#include "../test_util.hpp"

namespace {

llc::ScanSequence simSequence() {
  llc::SimDriveOptions options;
  options.length_m = 400.0;
  const llc::SimWorld world(llc::simWorldOptions(options));
  const llc::SimDrive drive = llc::simulateDrive(world, options);
  llc::ScanSequence sequence;
  for (const llc::SimFrame& frame : drive.frames) {
    llc::LoggedScan logged;
    logged.scan = llc_test::frameScan(drive, frame);
    logged.truth = frame.truth;
    logged.odometry = frame.odometry;
    logged.stamp = frame.stamp;
    sequence.scans.push_back(logged);
  }
  return sequence;
}

llc::OdometryOffsetResult estimate(const llc::ScanSequence& sequence, const llc::OdometryOffsetOptions& options = {}) {
  return llc::estimateOdometryOffset(sequence, llc::ScanOdometry{}, llc::ScanAligner{}, options);
}

}  // namespace

TEST(OdometryOffset, ShiftTakesTheOdometryOfAnotherScanAndRepeatsTheEnds) {
  llc::ScanSequence sequence;
  for (int i = 0; i < 5; ++i) {
    llc::LoggedScan s;
    s.odometry = {double(i), 0.0, 0.0};
    s.truth = {10.0 + i, 0.0, 0.0};
    sequence.scans.push_back(s);
  }
  llc::ScanSequence earlier = sequence, later = sequence, same = sequence;
  llc::shiftOdometry(&earlier, -1);
  llc::shiftOdometry(&later, 2);
  llc::shiftOdometry(&same, 0);
  const double expected_earlier[] = {0, 0, 1, 2, 3}, expected_later[] = {2, 3, 4, 4, 4};
  for (std::size_t i = 0; i < 5; ++i) {
    EXPECT_EQ(earlier.scans[i].odometry.x, expected_earlier[i]) << i;
    EXPECT_EQ(later.scans[i].odometry.x, expected_later[i]) << i;
    EXPECT_EQ(same.scans[i].odometry.x, double(i));
    EXPECT_EQ(later.scans[i].truth.x, 10.0 + double(i)) << "the truth does not move";
  }
  llc::ScanSequence empty;
  llc::shiftOdometry(&empty, 3);
  EXPECT_TRUE(empty.scans.empty());
}

TEST(OdometryOffset, FindsNoShiftInASimulatedDriveAndUndoesAPlantedOne) {
  const llc::ScanSequence sequence = simSequence();
  ASSERT_GT(sequence.scans.size(), 100u);
  const llc::OdometryOffsetResult in_step = estimate(sequence);
  ASSERT_TRUE(in_step.ok) << in_step.reason;
  EXPECT_EQ(in_step.best_offset, 0);
  ASSERT_EQ(in_step.scores.size(), 7u);
  EXPECT_EQ(in_step.scores.front().offset, -3);
  EXPECT_EQ(in_step.scores.back().offset, 3);
  // The further the shift, the more ICP corrects it: at steady speed every shift predicts the
  // same step, so only the turns and changes of speed of the drive make the difference.
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_GT(in_step.scores[k].mean_correction_rad, in_step.scores[k + 1].mean_correction_rad) << k;
    EXPECT_GT(in_step.scores[6 - k].mean_correction_rad, in_step.scores[5 - k].mean_correction_rad) << k;
  }

  // Odometry written two scans late: each scan carries the pose of the scan two later.
  llc::ScanSequence late = sequence;
  llc::shiftOdometry(&late, 2);
  const llc::OdometryOffsetResult found = estimate(late);
  ASSERT_TRUE(found.ok) << found.reason;
  EXPECT_EQ(found.best_offset, -2) << found.reason;
  EXPECT_NE(found.reason.find("offset -2 corrects"), std::string::npos) << found.reason;
  EXPECT_NE(found.reason.find("paired t"), std::string::npos) << found.reason;
  EXPECT_NE(in_step.reason.find("offset 0 corrects least"), std::string::npos) << in_step.reason;
  ASSERT_EQ(found.scores[1].correction_rad.size(), found.scores[1].pairs) << "one entry per pair, matched or not";
}

TEST(OdometryOffset, SaysWhyItCannotTell) {
  llc::ScanSequence sequence = simSequence();
  sequence.has_odometry = false;
  EXPECT_FALSE(estimate(sequence).ok);
  EXPECT_NE(estimate(sequence).reason.find("no odometry"), std::string::npos);

  llc::ScanSequence standing = simSequence();
  for (llc::LoggedScan& s : standing.scans) s.odometry = {};
  const llc::OdometryOffsetResult still = estimate(standing);
  EXPECT_FALSE(still.ok);
  EXPECT_NE(still.reason.find("fewer than 10"), std::string::npos);

  llc::ScanSequence blank = simSequence();
  for (llc::LoggedScan& s : blank.scans)
    for (double& r : s.scan.ranges) r = std::numeric_limits<double>::infinity();
  const llc::OdometryOffsetResult blind = estimate(blank);
  EXPECT_FALSE(blind.ok);
  EXPECT_NE(blind.reason.find("scan matching failed"), std::string::npos);

  llc::OdometryOffsetOptions bad;
  bad.max_pairs = 0;
  EXPECT_THROW(estimate(sequence, bad), std::invalid_argument);
  bad = {};
  bad.max_offset = -1;
  EXPECT_THROW(estimate(sequence, bad), std::invalid_argument);
}
