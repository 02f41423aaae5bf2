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

/// Two walls 3 m apart with `pillars` pillars, one every 3 m from x = -1, 1 m wide and
/// standing `depth` m out, in turn from each wall.
std::vector<llc_test::Wall> pillaredCorridor(int pillars = 4, double depth = 0.4) {
  auto walls = llc_test::corridor();
  for (int n = 0; n < pillars; ++n) {
    const double x = -1.0 + 3.0 * n, side = n % 2 ? 1.5 : -1.5, out = n % 2 ? -depth : depth;
    walls.push_back({{x, side}, {x, side + out}});
    walls.push_back({{x, side + out}, {x + 1.0, side + out}});
    walls.push_back({{x + 1.0, side + out}, {x + 1.0, side}});
  }
  return walls;
}

TEST(LaserOdometry, ALaserStepAlongACorridorIsUncertainAlongItsAxis) {
  // Two walls 3 m apart with a pillar every 3 m: ICP finds each step, but along the corridor
  // only the pillars' few points fix it. Without wheels the step's covariance says so.
  const auto walls = pillaredCorridor();
  const llc::OdometryStep laser = firstKeyframeStep(walls, false);
  ASSERT_TRUE(laser.matched) << laser.reject_reason;
  EXPECT_GT(laser.icp_covariance(0, 0), 5.0 * laser.icp_covariance(1, 1)) << "ICP's own: along against across";
  EXPECT_GT(laser.covariance(0, 0), 1.5 * laser.covariance(1, 1)) << "the step's (1.7x when written)";
  // With the scale at 0, the isotropic step model alone (as before).
  llc::ScanOdometryOptions off;
  off.icp_covariance_scale = 0.0;
  off.ambiguity_score_drop = 0.0;
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

TEST(LaserOdometry, AKeyframeStepAlongACorridorIsWidenedAsFarAsTheScanFitsAsWell) {
  const llc::ScanOdometryOptions options;
  const llc::OdometryStep laser = firstKeyframeStep(pillaredCorridor(1, 0.1), false, options);
  ASSERT_TRUE(laser.matched) << laser.reject_reason;
  RecordProperty("ambiguous_shift_m", std::to_string(laser.ambiguous_shift));
  // (One pillar 0.1 m deep: ICP is posed by it, but the scan fits within 0.02 of its best
  // over 0.4 m along the walls.)
  EXPECT_GE(laser.ambiguous_shift, 0.3);
  EXPECT_TRUE(laser.widened_along_ambiguity);
  // Along the corridor (ICP's weakest direction) the step now holds that shift; across it,
  // and in heading, nothing changed.
  llc::ScanOdometryOptions off = options;
  off.ambiguity_score_drop = 0.0;
  const llc::OdometryStep plain = firstKeyframeStep(pillaredCorridor(1, 0.1), false, off);
  ASSERT_TRUE(plain.matched);
  EXPECT_EQ(plain.ambiguous_shift, 0.0);
  EXPECT_NEAR(laser.covariance(0, 0), laser.ambiguous_shift * laser.ambiguous_shift, 0.05 * laser.covariance(0, 0));
  EXPECT_GT(laser.covariance(0, 0), 10.0 * plain.covariance(0, 0));
  EXPECT_NEAR(laser.covariance(1, 1), plain.covariance(1, 1), 0.01);
  EXPECT_DOUBLE_EQ(laser.covariance(2, 2), plain.covariance(2, 2));
  // The irregular room fixes the step: nothing to widen.
  const llc::OdometryStep room = firstKeyframeStep(llc_test::room(), false, options);
  const llc::OdometryStep room_plain = firstKeyframeStep(llc_test::room(), false, off);
  ASSERT_TRUE(room.matched);
  EXPECT_LE(room.ambiguous_shift, 0.1);
  EXPECT_TRUE(room.covariance.isApprox(room_plain.covariance, 1e-12));
  EXPECT_FALSE(room.widened_along_ambiguity);
  // With wheels they know the axis: not looked at.
  const llc::OdometryStep wheels = firstKeyframeStep(pillaredCorridor(1, 0.1), true, options);
  EXPECT_EQ(wheels.ambiguous_shift, 0.0);
  EXPECT_FALSE(wheels.widened_along_ambiguity);
}

TEST(LaserOdometry, AmbiguityLeavesStepsWithoutAnIcpCovarianceAlone) {
  const llc::ScanOdometry odometry;
  // A hall 10 m wide, its walls joined in the field within its 20 m; the scan's points within 8
  // m: shifted 10 m on from 1 m they stay within them.
  const std::vector<llc_test::Wall> hall = {{{-100, -5}, {100, -5}}, {{-100, 5}, {100, 5}}};
  const llc::LikelihoodField field(llc::scanPoints(llc_test::scanAt(hall, llc::Pose2{}, 360), 20.0),
                                   odometry.options().correlative);
  const llc::Points2 scan = llc::scanPoints(llc_test::scanAt(hall, llc::Pose2{1.0, 0, 0}, 360), 8.0);
  llc::OdometryStep step;
  step.motion = llc::Pose2{1.0, 0.0, 0.0};
  step.covariance = 0.01 * Eigen::Matrix3d::Identity();
  step.matched = true;  // but no ICP covariance: no direction to widen along
  EXPECT_FALSE(odometry.widenAlongAmbiguity(field, scan, step));
  step.icp_covariance = Eigen::Vector3d(1e-4, 1e-6, 1e-6).asDiagonal();
  step.matched = false;  // the guess, not ICP's
  EXPECT_FALSE(odometry.widenAlongAmbiguity(field, scan, step));
  step.matched = true;
  step.icp_covariance(0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(odometry.widenAlongAmbiguity(field, scan, step));
  EXPECT_TRUE(step.covariance.isApprox(0.01 * Eigen::Matrix3d::Identity()));
  EXPECT_FALSE(step.widened_along_ambiguity);
  step.icp_covariance(0, 0) = 1e-4;  // along x: the hall's axis, as far as it is asked
  EXPECT_TRUE(odometry.widenAlongAmbiguity(field, scan, step));
  EXPECT_DOUBLE_EQ(step.ambiguous_shift, odometry.options().ambiguity_max_shift);
  EXPECT_NEAR(step.covariance(0, 0), 100.0, 1e-9);
  EXPECT_NEAR(step.covariance(1, 1), 0.01, 1e-12);
  EXPECT_TRUE(step.widened_along_ambiguity);
}

TEST(ScanOdometryOptions, AmbiguityOptionsAreChecked) {
  llc::ScanOdometryOptions o;
  o.ambiguity_score_drop = -0.1;
  EXPECT_NE(o.validate().find("ambiguity_score_drop"), std::string::npos);
  o.ambiguity_score_drop = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(o.validate().find("ambiguity_score_drop"), std::string::npos);
  o = llc::ScanOdometryOptions{};
  o.ambiguity_max_shift = 0.0;
  EXPECT_NE(o.validate().find("ambiguity_max_shift"), std::string::npos);
  o.ambiguity_max_shift = std::numeric_limits<double>::infinity();
  EXPECT_NE(o.validate().find("ambiguity_max_shift"), std::string::npos);
  o.ambiguity_max_shift = 1e9;  // a slip of a digit: millions of poses scored per keyframe
  EXPECT_NE(o.validate().find("ambiguity_max_shift"), std::string::npos);
  o.ambiguity_max_shift = 2.0 * o.correlative.max_range;
  EXPECT_EQ(o.validate(), "");
}

}  // namespace
