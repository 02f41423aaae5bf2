// The front end without wheels: scans placed by the laser alone, predicted by the motion model
// on its clock (MotionClock), and matched from the last scan's pose when the prediction fails.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "laser_loop_closure/core/alignment/scan_aligner.hpp"
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

TEST(LaserOdometry, IcpsCovarianceIsCarriedIntoTheStepsParametersByHand) {
  llc::IcpResult icp;
  icp.pose = {1.0, 2.0, 0.3};
  icp.covariance = Eigen::Vector3d(0.01, 0.02, 0.001).asDiagonal();
  // A small motion (dx, dy, dtheta) before the pose moves (x, y) to (x + dx - y dtheta,
  // y + dy + x dtheta): with x = 1, y = 2 by hand.
  const Eigen::Matrix3d c = llc::ScanOdometry::stepCovarianceOf(icp);
  EXPECT_NEAR(c(0, 0), 0.01 + 4.0 * 0.001, 1e-12);
  EXPECT_NEAR(c(1, 1), 0.02 + 1.0 * 0.001, 1e-12);
  EXPECT_NEAR(c(2, 2), 0.001, 1e-12);
  EXPECT_NEAR(c(0, 1), -2.0 * 0.001, 1e-12);
  EXPECT_NEAR(c(0, 2), -2.0 * 0.001, 1e-12);
  EXPECT_NEAR(c(1, 2), 1.0 * 0.001, 1e-12);
  icp.covariance(0, 0) = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(llc::ScanOdometry::stepCovarianceOf(icp).isZero());
}

/// The first keyframe step (after scan 0) of a drive along +x through `walls`, 0.1 m a scan,
/// with or without the true motion as wheel odometry.
llc::OdometryStep firstKeyframeStep(const std::vector<llc_test::Wall>& walls, bool wheels,
                                    const llc::ScanOdometryOptions& options = {}) {
  llc::SlamFrontEnd front(llc_test::defaultModel(), options, llc::ScanAlignerOptions{}, llc::LoopDetectorOptions{});
  for (int k = 0; k < 30; ++k) {
    const llc::Pose2 pose{0.1 * k, 0.05 * std::sin(k), 0.003 * k};
    llc::Scan scan = llc_test::scanAt(walls, pose, 360);
    scan.stamp = 0.1 * k;
    const llc::FrontEndStep step = front.addScan(scan, wheels ? &pose : nullptr);
    if (step.keyframe && k > 0) return step.odometry;
  }
  ADD_FAILURE() << "no second keyframe";
  return {};
}

TEST(LaserOdometry, ALaserStepAlongACorridorIsUncertainAlongItsAxis) {
  // Two walls 3 m apart with a pillar every 3 m: ICP finds each step, but along the corridor
  // only the pillars' few points fix it. Without wheels the step's covariance says so.
  auto walls = llc_test::corridor();
  for (int n = 0; n < 4; ++n) {  // pillars 1 m wide standing 0.4 m out, in turn from each wall
    const double x = -1.0 + 3.0 * n, side = n % 2 ? 1.5 : -1.5, depth = n % 2 ? -0.4 : 0.4;
    walls.push_back({{x, side}, {x, side + depth}});
    walls.push_back({{x, side + depth}, {x + 1.0, side + depth}});
    walls.push_back({{x + 1.0, side + depth}, {x + 1.0, side}});
  }
  const llc::OdometryStep laser = firstKeyframeStep(walls, false);
  ASSERT_TRUE(laser.matched) << laser.reject_reason;
  EXPECT_GT(laser.icp_covariance(0, 0), 5.0 * laser.icp_covariance(1, 1)) << "ICP's own: along against across";
  EXPECT_GT(laser.covariance(0, 0), 1.5 * laser.covariance(1, 1)) << "the step's (1.7x when written)";
  // With the scale at 0, the isotropic step model alone (as before).
  llc::ScanOdometryOptions off;
  off.icp_covariance_scale = 0.0;
  const llc::OdometryStep plain = firstKeyframeStep(walls, false, off);
  ASSERT_TRUE(plain.matched);
  EXPECT_NEAR(plain.covariance(0, 0), plain.covariance(1, 1), 1e-12);
  // With wheels the step keeps the model: they know the axis by themselves.
  const llc::OdometryStep wheels = firstKeyframeStep(walls, true);
  ASSERT_TRUE(wheels.matched);
  EXPECT_NEAR(wheels.covariance(0, 0), wheels.covariance(1, 1), 1e-12);
  RecordProperty("sigma_along_m", std::to_string(std::sqrt(laser.covariance(0, 0))));
  RecordProperty("sigma_across_m", std::to_string(std::sqrt(laser.covariance(1, 1))));
}

}  // namespace
