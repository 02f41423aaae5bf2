// The front end without wheels: scans placed by the laser alone, predicted by the motion model
// on its clock (MotionClock), and matched from the last scan's pose when the prediction fails.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "laser_loop_closure/core/slam/slam_front_end.hpp"
#include "../synthetic_room.hpp"
#include "../test_util.hpp"

namespace {

struct LaserRun {
  llc::Pose2 last_pose;  ///< the last scan in the front end's own odometry frame
  std::size_t skipped = 0, keyframes = 0;
  llc::FrontEndCounters counters;
};

/// The irregular room's 360-beam scans at `poses` with these stamps, through a front end
/// without wheel odometry.
LaserRun runLaserOnly(const std::vector<llc::Pose2>& poses, const std::vector<double>& stamps,
                      const llc::ScanOdometryOptions& options = {}) {
  llc::SlamFrontEnd front(llc_test::defaultModel(), options, llc::ScanAlignerOptions{}, llc::LoopDetectorOptions{});
  const auto walls = llc_test::room();
  LaserRun run;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    llc::Scan scan = llc_test::scanAt(walls, poses[k], 360);
    scan.stamp = stamps[k];
    const llc::FrontEndStep step = front.addScan(scan, nullptr);
    run.skipped += !step.skip_reason.empty();
    run.keyframes += step.keyframe;
    if (step.has_odometry_pose) run.last_pose = step.odometry_pose;
  }
  run.counters = front.counters();
  return run;
}

TEST(LaserOdometry, ATurnInPlaceIsFollowedThroughStampsThatJitterAndGoBack) {
  // Taken every 0.2 s while turning 0.25 rad a scan and creeping 2 cm, stamped up to 0.3 s late
  // (as the Intel log's scans: intervals from -0.1 to 0.5 s, some stamps older than the scan
  // before). Velocities from these stamps say anything from 0 to 10x the turn.
  const double late[] = {0.0, 0.3, 0.05, 0.25, 0.0, 0.28, 0.02, 0.1, 0.3, 0.0, 0.2};
  std::vector<llc::Pose2> poses;
  std::vector<double> stamps;
  for (int k = 0; k < 120; ++k) {
    poses.push_back({-2.0 + 0.02 * k, 0.5, 0.25 * k});
    stamps.push_back(100.0 + 0.2 * k + late[k % 11]);
  }
  const llc::Pose2 truth = llc::between(poses.front(), poses.back());
  const LaserRun counted = runLaserOnly(poses, stamps);
  // Once the clock has judged the stamps (16 intervals), every scan is taken as it comes, and
  // predicted well enough for ICP from there.
  EXPECT_LE(counted.skipped, llc::MotionClock::min_intervals);
  EXPECT_GE(counted.counters.scans_counted, 80u);  // most: a window of these can look steady (89 when written)
  EXPECT_LE(counted.counters.laser_fallback_steps, 2u);
  EXPECT_NEAR(counted.last_pose.x, truth.x, 0.05);
  EXPECT_NEAR(counted.last_pose.y, truth.y, 0.05);
  EXPECT_NEAR(llc::normalizeAngle(counted.last_pose.theta - truth.theta), 0.0, 0.02);
  // Read as they are (when written: 22 skipped as "time went backwards", 8 predictions ICP
  // failed from, a scan's turn lost), the stamps do worse.
  llc::ScanOdometryOptions stamps_only;
  stamps_only.max_stamp_jitter = std::numeric_limits<double>::infinity();
  const LaserRun read = runLaserOnly(poses, stamps, stamps_only);
  EXPECT_EQ(read.counters.scans_counted, 0u);
  EXPECT_GT(read.skipped, counted.skipped + 10);
  EXPECT_GT(read.counters.laser_fallback_steps, counted.counters.laser_fallback_steps + 4);
  RecordProperty("skipped_counted", int(counted.skipped));
  RecordProperty("skipped_stamps_only", int(read.skipped));
  RecordProperty("heading_error_stamps_only", std::to_string(llc::normalizeAngle(read.last_pose.theta - truth.theta)));
}

TEST(LaserOdometry, WhenThePredictionFailsTheScanIsMatchedFromWhereTheLastOneStood) {
  // A fast turn (0.3 rad every 0.2 s), then the robot stops; the next scan comes 0.8 s later,
  // where the velocity predicts 1.2 rad more turn than there was.
  std::vector<llc::Pose2> poses;
  std::vector<double> stamps;
  for (int k = 0; k < 6; ++k) poses.push_back({0.0, 0.0, 0.3 * k}), stamps.push_back(10.0 + 0.2 * k);
  for (int k = 0; k < 4; ++k) poses.push_back(poses.back()), stamps.push_back(stamps.back() + (k == 0 ? 0.8 : 0.2));
  const LaserRun run = runLaserOnly(poses, stamps);
  EXPECT_GE(run.counters.laser_fallback_steps, 1u);
  const llc::Pose2 truth = llc::between(poses.front(), poses.back());
  EXPECT_NEAR(llc::normalizeAngle(run.last_pose.theta - truth.theta), 0.0, 0.02);
  EXPECT_NEAR(run.last_pose.x, truth.x, 0.03);
  EXPECT_NEAR(run.last_pose.y, truth.y, 0.03);
}

}  // namespace
