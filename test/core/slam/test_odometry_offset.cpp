// Odometry out of step with the scans: shifting it, and finding the shift from the scans.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>

#include "laser_loop_closure/core/slam/odometry_offset.hpp"
#include "laser_loop_closure/core/slam/odometry_time_offset_probe.hpp"
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

namespace {

/// The sim drive's odometry at any time in its span (linear between frames), as tf gives it.
std::function<bool(double, llc::Pose2*)> trackOf(const llc::ScanSequence& sequence) {
  return [&sequence](double t, llc::Pose2* pose) {
    const auto& scans = sequence.scans;
    if (scans.empty() || t < scans.front().stamp || t > scans.back().stamp) return false;
    auto after = std::lower_bound(scans.begin(), scans.end(), t,
                                  [](const llc::LoggedScan& s, double time) { return s.stamp < time; });
    if (after == scans.begin()) {
      *pose = after->odometry;
      return true;
    }
    const llc::LoggedScan& b = *after;
    const llc::LoggedScan& a = *(after - 1);
    const double f = (t - a.stamp) / (b.stamp - a.stamp);
    *pose = {a.odometry.x + f * (b.odometry.x - a.odometry.x), a.odometry.y + f * (b.odometry.y - a.odometry.y),
             llc::normalizeAngle(a.odometry.theta + f * llc::normalizeAngle(b.odometry.theta - a.odometry.theta))};
    return true;
  };
}

/// Feeds every scan, stamped `late` s after it was taken, to a probe; the offsets it returned.
std::vector<double> probe(const llc::ScanSequence& sequence, double late, llc::OdometryTimeOffsetProbe* p) {
  const auto track = trackOf(sequence);
  std::vector<double> offsets;
  for (const llc::LoggedScan& s : sequence.scans) {
    const double stamp = s.stamp + late;
    offsets.push_back(p->observe(stamp, s.scan, [&](double offset, llc::Pose2* pose) { return track(stamp + offset, pose); }));
  }
  return offsets;
}

}  // namespace

TEST(OdometryTimeOffsetProbe, FindsScansStampedLateByWholePeriodsAndHoldsTheInitialOffsetUntilThen) {
  const llc::ScanSequence sequence = simSequence();
  const double period = sequence.scans[1].stamp - sequence.scans[0].stamp;
  ASSERT_GT(period, 0.0);
  // The simulated drive turns seldom: 22 of its 632 pairs part by 0.01 rad.
  llc::OdometryTimeOffsetProbeOptions options;
  options.pairs = 20;
  for (const int late_periods : {0, 1, 2}) {
    llc::OdometryTimeOffsetProbe p(llc::ScanOdometry{}, llc::ScanAligner{}, -0.5 * period, options);
    const std::vector<double> offsets = probe(sequence, late_periods * period, &p);
    const llc::OdometryTimeOffsetProbeResult& r = p.result();
    ASSERT_TRUE(r.decided) << late_periods << " pairs " << r.moving_pairs << " of scans " << r.scans;
    ASSERT_TRUE(r.estimate.ok) << r.estimate.reason;
    EXPECT_NEAR(r.period, period, 1e-9);
    EXPECT_EQ(r.estimate.best_offset, -late_periods) << r.estimate.reason;
    EXPECT_NEAR(r.offset, -late_periods * period, 1e-9);
    EXPECT_EQ(r.moving_pairs, options.pairs);
    ASSERT_EQ(r.estimate.scores.size(), 4u) << "0 to 3 periods back";
    EXPECT_EQ(r.estimate.scores.back().offset, -3);
    // The initial offset up to the choice, the chosen one from the scan that completed it on.
    ASSERT_LT(r.decided_at_scan, offsets.size());
    for (std::size_t i = 0; i < offsets.size(); ++i)
      EXPECT_EQ(offsets[i], i < r.decided_at_scan ? -0.5 * period : r.offset) << i;
    if (late_periods > 0) {
      EXPECT_NE(r.estimate.reason.find("periods of"), std::string::npos) << r.estimate.reason;
    }
  }
}

TEST(OdometryTimeOffsetProbe, KeepsTheInitialOffsetWhereTheScansCannotTellAndRefusesBadOptions) {
  llc::ScanSequence standing = simSequence();
  for (llc::LoggedScan& s : standing.scans) s.odometry = {};
  llc::OdometryTimeOffsetProbe still(llc::ScanOdometry{}, llc::ScanAligner{}, -0.1);
  for (const double offset : probe(standing, 0.0, &still)) EXPECT_EQ(offset, -0.1);
  EXPECT_FALSE(still.result().decided) << "a robot that never moves never decides";
  EXPECT_EQ(still.result().moving_pairs, 0u);

  llc::ScanSequence blank = simSequence();
  for (llc::LoggedScan& s : blank.scans)
    for (double& r : s.scan.ranges) r = std::numeric_limits<double>::infinity();
  llc::OdometryTimeOffsetProbeOptions few;
  few.pairs = 20;
  llc::OdometryTimeOffsetProbe blind(llc::ScanOdometry{}, llc::ScanAligner{}, -0.1, few);
  probe(blank, 0.0, &blind);
  EXPECT_TRUE(blind.result().decided);
  EXPECT_FALSE(blind.result().estimate.ok);
  EXPECT_EQ(blind.result().offset, -0.1) << blind.result().estimate.reason;

  // Stamps going back, and no odometry at all: no pair, no crash.
  llc::OdometryTimeOffsetProbe none(llc::ScanOdometry{}, llc::ScanAligner{}, 0.0);
  const llc::OdometryLookup nothing = [](double, llc::Pose2*) { return false; };
  const llc::ScanSequence sequence = simSequence();
  for (std::size_t i = 0; i < 200; ++i) none.observe(100.0 - double(i % 30), sequence.scans[i].scan, nothing);
  EXPECT_EQ(none.result().moving_pairs, 0u);
  EXPECT_EQ(none.result().offset, 0.0);

  llc::OdometryTimeOffsetProbeOptions bad;
  bad.pairs = 3;
  EXPECT_THROW(llc::OdometryTimeOffsetProbe(llc::ScanOdometry{}, llc::ScanAligner{}, 0.0, bad), std::invalid_argument);
  EXPECT_THROW(llc::OdometryTimeOffsetProbe(llc::ScanOdometry{}, llc::ScanAligner{}, std::nan(""), {}), std::invalid_argument);

  // The nodelets' rule: stamp + offset, else the stamp itself.
  auto from_ten = [](double stamp) -> llc::OdometryLookup {
    return [stamp](double offset, llc::Pose2* pose) {
      if (stamp + offset < 10.0) return false;
      *pose = {stamp + offset, 0.0, 0.0};
      return true;
    };
  };
  llc::Pose2 pose;
  ASSERT_TRUE(llc::OdometryTimeOffsetProbe::readAt(from_ten(10.5), -0.2, &pose));
  EXPECT_DOUBLE_EQ(pose.x, 10.3);
  ASSERT_TRUE(llc::OdometryTimeOffsetProbe::readAt(from_ten(10.1), -0.2, &pose));
  EXPECT_DOUBLE_EQ(pose.x, 10.1) << "before the first reading: the stamp's";
  EXPECT_FALSE(llc::OdometryTimeOffsetProbe::readAt(from_ten(9.0), -0.2, &pose));
}
