// Scan-matching odometry without wheels through the front end: the motion model carries it
// through a stretch that scan matching cannot measure.
#include <gtest/gtest.h>

#include <Eigen/LU>
#include <cmath>
#include <limits>
#include <vector>

#include "laser_loop_closure/core/slam/odometry_prior_gate.hpp"
#include "laser_loop_closure/core/slam/slam_front_end.hpp"
#include "../test_util.hpp"

namespace {

struct Wall {
  double ax, ay, bx, by;
};

/// Range along the ray from (x, y) at `angle` to the nearest wall within 30 m, else +inf.
double castRay(const std::vector<Wall>& walls, double x, double y, double angle) {
  const double dx = std::cos(angle), dy = std::sin(angle);
  double nearest = std::numeric_limits<double>::infinity();
  for (const Wall& w : walls) {
    const double ex = w.bx - w.ax, ey = w.by - w.ay;
    const double denominator = dx * ey - dy * ex;
    if (std::abs(denominator) < 1e-12) continue;
    const double t = ((w.ax - x) * ey - (w.ay - y) * ex) / denominator;  // along the ray
    const double s = ((w.ax - x) * dy - (w.ay - y) * dx) / denominator;  // along the wall
    if (t > 0.0 && s >= 0.0 && s <= 1.0) nearest = std::min(nearest, t);
  }
  return nearest <= 30.0 ? nearest : std::numeric_limits<double>::infinity();
}

/// A corridor 6 m wide along x: niches every 3 m in its first 20 m, then bare walls for 200 m.
std::vector<Wall> corridor() {
  std::vector<Wall> walls = {{-10, -3, 220, -3}, {-10, 3, 220, 3}, {-10, -3, -10, 3}};
  for (double x = 0.0; x <= 20.0; x += 3.0) {
    walls.push_back({x, 3, x, 2.2});
    walls.push_back({x + 0.7, -3, x + 0.7, -2.4});
  }
  return walls;
}

struct DriveResult {
  std::size_t keyframes = 0;
  double travelled = 0.0;  ///< x of the newest keyframe by the composed keyframe motions
};

/// The scan 360 beams see at x along the corridor (y wavers by 0.1 m).
llc::Scan corridorScan(const std::vector<Wall>& walls, int k) {
  const double x = 0.7 * k, y = 0.1 * std::sin(0.05 * k);
  llc::Scan scan = llc_test::ringScan(std::vector<double>(360));
  for (std::size_t i = 0; i < scan.ranges.size(); ++i) scan.ranges[i] = castRay(walls, x, y, scan.bearings[i]);
  return scan;
}

/// Drives along the corridor at 7 m/s, scanning 360 beams at 10 Hz, with no wheel odometry.
DriveResult drive(bool predict_motion, double seconds) {
  llc::ScanOdometryOptions odometry;
  odometry.predict_motion = predict_motion;
  llc::SlamFrontEnd front(llc_test::defaultModel(), odometry, llc::ScanAlignerOptions{}, llc::LoopDetectorOptions{});
  const std::vector<Wall> walls = corridor();
  DriveResult run;
  llc::Pose2 newest;
  for (int k = 0; 0.1 * k <= seconds; ++k) {
    llc::Scan scan = corridorScan(walls, k);
    scan.stamp = 100.0 + 0.1 * k;
    const llc::FrontEndStep step = front.addScan(scan, nullptr);
    EXPECT_TRUE(step.skip_reason.empty()) << step.skip_reason;
    if (!step.keyframe) continue;
    if (run.keyframes++ > 0) newest = llc::compose(newest, step.odometry.motion);
  }
  run.travelled = newest.x;
  return run;
}

TEST(ScanOdometry, WithoutWheelsTheMotionModelCarriesKeyframesThroughABareCorridor) {
  // 20 s: 140 m, of which 120 m between bare walls, where only the velocity measured in the
  // first 20 m tells how far the robot went.
  const DriveResult predicted = drive(true, 20.0);
  EXPECT_GE(predicted.keyframes, 90u) << "a keyframe every 1.4 m (two scans)";
  EXPECT_NEAR(predicted.travelled, 140.0, 7.0);  // 134.9 m when written
  // Without a motion model the odometry stands still where matching loses the corridor's
  // length, and then no scan is ever far enough from the keyframe to make a new one.
  const DriveResult standing = drive(false, 20.0);
  // test_core --gtest_output=xml:F.xml writes these.
  RecordProperty("keyframes_with_model", int(predicted.keyframes));
  RecordProperty("travelled_with_model_m", std::to_string(predicted.travelled));
  RecordProperty("keyframes_without_model", int(standing.keyframes));
  RecordProperty("travelled_without_model_m", std::to_string(standing.travelled));
  EXPECT_LT(standing.keyframes, 40u);
  EXPECT_LT(standing.travelled, 60.0);  // 17 keyframes, 22.4 m when written
}

TEST(ScanOdometry, OddStampsAreNotPredictedFromAndNothingBreaks) {
  // Among the niches (ICP well posed): a repeated stamp, a scan earlier than the one before
  // (but after the newest keyframe), and a 5 s gap (beyond max_prediction_gap). None is used
  // to extrapolate; every motion stays finite and keyframes go on.
  llc::SlamFrontEnd front(llc_test::defaultModel(), llc::ScanOdometryOptions{}, llc::ScanAlignerOptions{}, llc::LoopDetectorOptions{});
  const std::vector<Wall> walls = corridor();
  const std::vector<double> stamps = {0.0, 0.1, 0.2, 0.3, 0.3, 0.35, 0.34, 5.34, 5.44, 5.54, 5.64, 5.74};
  std::size_t keyframes = 0;
  for (std::size_t k = 0; k < stamps.size(); ++k) {
    llc::Scan scan = corridorScan(walls, int(k));
    scan.stamp = 100.0 + stamps[k];
    const llc::FrontEndStep step = front.addScan(scan, nullptr);
    if (!step.skip_reason.empty()) {
      EXPECT_EQ(step.skip_reason, "time went backwards") << "scan " << k;
      continue;
    }
    const llc::Pose2& m = step.odometry.motion;
    EXPECT_TRUE(std::isfinite(m.x) && std::isfinite(m.y) && std::isfinite(m.theta)) << "scan " << k;
    keyframes += step.keyframe;
  }
  EXPECT_GE(keyframes, 5u) << "0.7 m a scan: a keyframe every second scan";
}

TEST(ScanOdometry, TheFrontEndsOwnOdometryFrameChainsItsMotionsAndNeverJumps) {
  // Without wheels the loop_closure nodelet broadcasts odom -> base_link from the front end's
  // own chain: each keyframe's pose the composition of the keyframe motions, a scan between
  // keyframes the newest keyframe's pose and the scan's motion from it; after time jumps back
  // (a looped bag) the new chain starts where the old one ended.
  llc::SlamFrontEnd front(llc_test::defaultModel(), llc::ScanOdometryOptions{}, llc::ScanAlignerOptions{},
                          llc::LoopDetectorOptions{});
  const std::vector<Wall> walls = corridor();
  llc::Pose2 keyframe_pose;
  bool has_keyframe = false;
  std::size_t keyframes = 0, between = 0, jumps = 0;
  for (int pass = 0; pass < 2; ++pass) {
    for (int k = 0; k < 20; ++k) {
      llc::Scan scan = corridorScan(walls, k);
      scan.stamp = 100.0 - 30.0 * pass + 0.1 * k;  // the second pass: time jumps back 31.9 s
      const llc::FrontEndStep step = front.addScan(scan, nullptr);
      ASSERT_TRUE(step.skip_reason.empty()) << step.skip_reason;
      ASSERT_TRUE(step.has_odometry_pose) << "pass " << pass << " scan " << k;
      jumps += !step.time_jump.empty();
      const llc::Pose2 expected = !has_keyframe ? llc::Pose2{}
                                  : !step.time_jump.empty() ? keyframe_pose  // a new chain goes on from here
                                                            : llc::compose(keyframe_pose, step.odometry.motion);
      EXPECT_NEAR(step.odometry_pose.x, expected.x, 1e-12) << "pass " << pass << " scan " << k;
      EXPECT_NEAR(step.odometry_pose.y, expected.y, 1e-12);
      EXPECT_NEAR(step.odometry_pose.theta, expected.theta, 1e-12);
      if (step.keyframe) keyframe_pose = step.odometry_pose, has_keyframe = true, ++keyframes;
      else ++between;
    }
  }
  EXPECT_EQ(jumps, 1u);
  EXPECT_GT(keyframes, 5u);
  EXPECT_GT(between, 5u);
  EXPECT_GT(keyframe_pose.x, 0.7 * 19 + 3.0) << "the second pass goes on past the first";
}

TEST(ScanOdometry, MatchEveryScanGivesAScanBetweenKeyframesItsOwnPose) {
  // Wheels that read 10% short: a scan between keyframes sits where the wheels put it, unless
  // match_every_scan matches it too (then where ICP puts it, the truth); keyframes are the same.
  const std::vector<Wall> walls = corridor();
  for (const bool every : {false, true}) {
    llc::ScanOdometryOptions odometry;
    odometry.match_every_scan = every;
    llc::SlamFrontEnd front(llc_test::defaultModel(), odometry, llc::ScanAlignerOptions{}, llc::LoopDetectorOptions{});
    std::size_t between = 0, keyframes = 0;
    double last_keyframe_x = 0.0;
    for (int k = 0; k < 20; ++k) {  // 0.7 m a scan, in the corridor's first 14 m (niches: ICP is posed)
      llc::Scan scan = corridorScan(walls, k);
      scan.stamp = 100.0 + 0.1 * k;
      const llc::Pose2 wheels{0.9 * 0.7 * k, 0.0, 0.0};
      const llc::FrontEndStep step = front.addScan(scan, &wheels);
      ASSERT_TRUE(step.has_odometry_pose);
      const double true_x = 0.7 * k;
      if (step.keyframe) {
        last_keyframe_x = true_x, ++keyframes;
        continue;
      }
      ++between;
      const double from_keyframe = true_x - last_keyframe_x;
      if (every) {
        EXPECT_TRUE(step.odometry.matched) << k;
        EXPECT_NEAR(step.odometry.motion.x, from_keyframe, 0.03) << "ICP's pose, scan " << k;
      } else {
        EXPECT_NEAR(step.odometry.motion.x, 0.9 * from_keyframe, 1e-9) << "the wheels' guess, scan " << k;
      }
    }
    EXPECT_GT(between, 5u);
    EXPECT_GT(keyframes, 5u);
  }
}

/// The corridor's niche section seen from (x, y) heading theta: 360 beams.
llc::Scan scanAt(const std::vector<Wall>& walls, double x, double y, double theta, double stamp) {
  llc::Scan scan = llc_test::ringScan(std::vector<double>(360));
  for (std::size_t i = 0; i < scan.ranges.size(); ++i) scan.ranges[i] = castRay(walls, x, y, theta + scan.bearings[i]);
  scan.stamp = stamp;
  return scan;
}

TEST(ScanOdometry, TrackedScansFollowATurnTheWheelsGetWrong) {
  // Turning on the spot, 0.03 rad a scan to the left, while the wheels slip and say 0.02 to the
  // right: at the next keyframe (the wheels' 0.35 rad) they are 0.9 rad off, beyond one ICP and
  // the correlative recovery's window. Tracked from scan to scan (each 0.05 rad off), ICP
  // follows the truth; without tracking the step is the wheels' or a wrong minimum.
  const std::vector<Wall> walls = corridor();
  for (const bool track : {true, false}) {
    llc::ScanOdometryOptions odometry;
    odometry.match_every_scan = true;
    odometry.track_scans = track;
    llc::SlamFrontEnd front(llc_test::defaultModel(), odometry, llc::ScanAlignerOptions{}, llc::LoopDetectorOptions{});
    std::size_t keyframes = 0;
    for (int k = 0; k <= 18; ++k) {
      const llc::Pose2 wheels{0.0, 0.0, -0.02 * k};
      const llc::FrontEndStep step = front.addScan(scanAt(walls, 4.0, 0.5, 0.03 * k, 100.0 + 0.1 * k), &wheels);
      ASSERT_EQ(step.keyframe, k == 0 || k == 18) << k;
      if (!step.keyframe) continue;
      ++keyframes;
      if (k == 0) continue;
      if (track) {
        EXPECT_TRUE(step.odometry.matched);
        EXPECT_TRUE(step.odometry.tracked);
        EXPECT_NEAR(step.odometry.motion.theta, 0.03 * k, 0.01);
        EXPECT_NEAR(std::hypot(step.odometry.motion.x, step.odometry.motion.y), 0.0, 0.03);
      } else {
        EXPECT_FALSE(step.odometry.tracked);
        EXPECT_GT(std::abs(step.odometry.motion.theta - 0.03 * k), 0.3) << "the wheels' turn, or ICP's wrong minimum";
      }
    }
    EXPECT_EQ(keyframes, 2u);
    EXPECT_EQ(front.counters().tracked_steps, track ? 1u : 0u);
  }
}

TEST(ScanOdometry, TrackingDoesNotCountTheMotionOfStalledWheelsTwice) {
  // Turning 0.06 rad a scan while the wheels stall for fourteen scans, then catch up at once:
  // the tracked guess (ICP's pose before, plus the wheels' catch-up) is 0.84 rad ahead, the
  // wheels' own guess right. The keyframe's step is the truth (MIT CSAIL's odometry stalls so).
  // (With stalled_wheels_as_missing off: on, the laser makes keyframes in the stall.)
  const std::vector<Wall> walls = corridor();
  llc::ScanOdometryOptions odometry;
  odometry.match_every_scan = true;
  odometry.stalled_wheels_as_missing = false;
  llc::SlamFrontEnd front(llc_test::defaultModel(), odometry, llc::ScanAlignerOptions{}, llc::LoopDetectorOptions{});
  std::size_t keyframes = 0;
  for (int k = 0; k <= 17; ++k) {
    const double true_theta = 0.06 * k;
    const llc::Pose2 wheels{0.0, 0.0, 0.06 * ((k >= 3 && k <= 16) ? 2 : k)};
    const llc::FrontEndStep step = front.addScan(scanAt(walls, 4.0, 0.5, true_theta, 100.0 + 0.1 * k), &wheels);
    ASSERT_EQ(step.keyframe, k == 0 || k == 17) << k;
    if (k == 0) continue;
    ASSERT_TRUE(step.odometry.matched) << k;
    EXPECT_NEAR(step.odometry.motion.theta, true_theta, 0.01) << "scan " << k << (step.keyframe ? " (keyframe)" : "");
    EXPECT_NEAR(std::hypot(step.odometry.motion.x, step.odometry.motion.y), 0.0, 0.03) << k;
    keyframes += step.keyframe;
  }
  EXPECT_EQ(keyframes, 1u);
  EXPECT_EQ(front.counters().stalled_wheel_scans, 0u);
}

/// scanAt's front half: 180 degrees, as MIT CSAIL's scanner sees.
llc::Scan frontScanAt(const std::vector<Wall>& walls, double x, double y, double theta, double stamp) {
  const llc::Scan ring = scanAt(walls, x, y, theta, stamp);
  llc::Scan scan = ring;
  scan.ranges.clear(), scan.bearings.clear();
  scan.full_circle = false;
  for (std::size_t i = 0; i < ring.ranges.size(); ++i)
    if (std::abs(ring.bearings[i]) <= M_PI / 2) scan.ranges.push_back(ring.ranges[i]), scan.bearings.push_back(ring.bearings[i]);
  return scan;
}

TEST(ScanOdometry, StalledWheelsArePassedOverAndTheLaserMakesTheKeyframesMeanwhile) {
  // Turning 0.15 rad a scan with a 180-degree scanner while the wheels all but repeat one
  // reading for ten scans, then catch up at once (MIT CSAIL's wheels: 0.87 rad in one reading after 1 s of
  // none). Found stalled, each scan is placed by the laser (predicted on by its last velocity),
  // keyframes come every 0.35 rad as the laser turns, and a keyframe made in the stall takes
  // no wheel reference: the scans after the catch-up are not thrown ahead. Off, no keyframe
  // comes in the stall: the scans are matched to one 1.5 rad behind (this clean corridor
  // still overlaps there; MIT CSAIL's scans did not).
  const std::vector<Wall> walls = corridor();
  for (const bool as_missing : {true, false}) {
    llc::ScanOdometryOptions odometry;
    odometry.match_every_scan = true;
    odometry.stalled_wheels_as_missing = as_missing;
    llc::SlamFrontEnd front(llc_test::defaultModel(), odometry, llc::ScanAlignerOptions{}, llc::LoopDetectorOptions{});
    double worst = 0.0;
    std::size_t keyframes_in_stall = 0;
    for (int k = 0; k <= 20; ++k) {
      const double true_theta = 0.15 * k;
      // (In the stall the reading creeps 1 mrad a scan, as one looked up between two messages.)
      const llc::Pose2 wheels{0.0, 0.0, (k >= 4 && k <= 13) ? 0.45 + 0.001 * (k - 4) : 0.15 * k};
      const llc::FrontEndStep step = front.addScan(frontScanAt(walls, 4.0, 0.5, true_theta, 100.0 + 0.2 * k), &wheels);
      ASSERT_TRUE(step.has_odometry_pose) << k;
      const double off = std::abs(llc::normalizeAngle(step.odometry_pose.theta - true_theta));
      worst = std::max(worst, off);
      keyframes_in_stall += step.keyframe && k > 4 && k <= 13;
    }
    EXPECT_LT(worst, 0.02) << "every scan where it truly is";
    if (as_missing) {
      EXPECT_GE(front.counters().stalled_wheel_scans, 1u);
      EXPECT_EQ(keyframes_in_stall, 3u) << "at 0.9, 1.35 and 1.8 rad";
    } else {
      EXPECT_EQ(front.counters().stalled_wheel_scans, 0u);
      EXPECT_EQ(keyframes_in_stall, 0u);
    }
  }
}

TEST(ScanOdometry, ARobotThatStandsStillIsNotTakenForStalledWheels) {
  // Driving 0.1 m a scan along the corridor, then standing for ten scans: the repeated reading
  // is what the laser sees too: nothing is called stalled, and every scan is where it is.
  const std::vector<Wall> walls = corridor();
  llc::ScanOdometryOptions odometry;
  odometry.match_every_scan = true;
  llc::SlamFrontEnd front(llc_test::defaultModel(), odometry, llc::ScanAlignerOptions{}, llc::LoopDetectorOptions{});
  for (int k = 0; k <= 30; ++k) {
    const double x = 0.1 * (k < 8 ? k : (k < 18 ? 8 : k - 10));
    const llc::Pose2 wheels{x, 0.0, 0.0};
    const llc::FrontEndStep step = front.addScan(scanAt(walls, 1.0 + x, 0.5, 0.0, 100.0 + 0.2 * k), &wheels);
    ASSERT_TRUE(step.has_odometry_pose) << k;
    EXPECT_NEAR(step.odometry_pose.x, x, 0.03) << k;
  }
  EXPECT_EQ(front.counters().stalled_wheel_scans, 0u);
}

TEST(ScanOdometry, TheSeedMarginIsValidated) {
  llc::ScanOdometryOptions options;
  for (const double bad : {-0.1, 1.5, std::nan("")}) {
    options.seed_min_score_gain = bad;
    EXPECT_NE(options.validate().find("seed_min_score_gain must be in [0, 1]"), std::string::npos) << bad;
  }
  options.seed_min_score_gain = 0.0;
  EXPECT_EQ(options.validate(), "");
}

TEST(ScanOdometry, PredictionOptionsAreValidated) {
  llc::ScanOdometryOptions options;
  for (const double bad : {-0.1, std::nan(""), std::numeric_limits<double>::infinity()}) {
    options.max_prediction_gap = bad;
    EXPECT_NE(options.validate().find("max_prediction_gap"), std::string::npos) << bad;
  }
  options.max_prediction_gap = 0.0;  // allowed: never predict
  EXPECT_EQ(options.validate(), "");
}

}  // namespace

namespace {

TEST(ScanOdometry, TheFrontEndFeedsTheCalibrationPairsItsOwnOdometryPutsSurelyApart) {
  // 140 m of straight corridor, a keyframe every 1.4 m: keyframes 15+ m apart and at most 50 m
  // driven apart are surely two places by the front end's own odometry.
  for (const bool enabled : {true, false}) {
    llc::LoopDetectorOptions loops;
    loops.calibration.enabled = enabled;
    loops.calibration.min_pairs = 200;
    llc::SlamFrontEnd front(llc_test::defaultModel(), llc::ScanOdometryOptions{}, llc::ScanAlignerOptions{}, loops);
    const std::vector<Wall> walls = corridor();
    for (int k = 0; k <= 200; ++k) {
      llc::Scan scan = corridorScan(walls, k);
      scan.stamp = 100.0 + 0.1 * k;
      const llc::FrontEndStep step = front.addScan(scan, nullptr);
      if (step.keyframe) front.detectLoops(step.keyframe_index);
    }
    const std::size_t pairs = front.counters().calibration_pairs;
    if (!enabled) {
      EXPECT_EQ(pairs, 0u);
      EXPECT_DOUBLE_EQ(front.detector().threshold(), llc_test::defaultModel().classifier.thresholdK());
      continue;
    }
    EXPECT_GT(pairs, 200u);
    EXPECT_LE(pairs, loops.calibration.pairs_per_keyframe * front.keyframeCount());
    EXPECT_EQ(front.detector().calibrator().seen(), pairs);
    EXPECT_TRUE(front.detector().calibrator().calibrated());
  }
}

/// A 12 x 8 m room with a pillar and two niches.
std::vector<Wall> roomWalls() {
  return {{-6, -4, 6, -4}, {6, -4, 6, 4},   {6, 4, -6, 4},    {-6, 4, -6, -4}, {1, 1, 2, 1},
          {2, 1, 2, 1.5},  {2, 1.5, 1, 1.5}, {1, 1.5, 1, 1}, {-3, 4, -3, 3.2}, {4, -4, 4, -3.5}};
}

/// The room of roomWalls as 360 beams see it from `pose`.
llc::Scan roomScan(const llc::Pose2& pose) {
  const std::vector<Wall> walls = roomWalls();
  llc::Scan scan = llc_test::ringScan(std::vector<double>(360));
  for (std::size_t i = 0; i < scan.ranges.size(); ++i)
    scan.ranges[i] = castRay(walls, pose.x, pose.y, pose.theta + scan.bearings[i]);
  return scan;
}

TEST(ScanOdometry, AStepWhereIcpAndWheelsDisagreeGetsACovarianceHoldingBoth) {
  const llc::Pose2 truth{1.0, 0.2, 0.1};
  const llc::ScanAligner aligner;
  const auto first = aligner.prepare(roomScan({}));
  const auto second = aligner.prepare(roomScan(truth));
  llc::ScanOdometryOptions hold_both;  // max_wheel_disagreement 9 under the wheel covariance
  hold_both.correlative_recovery = false;  // (on, the laser overrules wheels this far off: below)
  const llc::ScanOdometry odometry(hold_both);
  // chi2 of a guess off the truth (where ICP lands) under the wheel covariance of that guess:
  // sigma 5 x (0.02 + 0.01 x distance) m, so about 3.3 for 0.3 m and 13 for 0.6 m.
  const auto chi2 = [&](const llc::Pose2& guess) {
    const Eigen::Vector3d d(truth.x - guess.x, truth.y - guess.y, truth.theta - guess.theta);
    return d.dot(odometry.stepCovariance(guess, false).inverse() * d);
  };
  const llc::Pose2 near_guess = llc::compose(truth, {0.3, 0.0, 0.0});
  const llc::OdometryStep near = odometry.match(*first, *second, {near_guess, true});
  ASSERT_TRUE(near.matched) << near.reject_reason;
  EXPECT_FALSE(near.disputed);
  EXPECT_NEAR(near.wheel_disagreement, chi2(near_guess), 0.1 * chi2(near_guess));
  EXPECT_TRUE(near.covariance.isApprox(odometry.stepCovariance(near.motion, true)));

  const llc::Pose2 far_guess = llc::compose(truth, {0.6, 0.0, 0.0});
  ASSERT_GT(chi2(far_guess), 10.0);
  const llc::OdometryStep far = odometry.match(*first, *second, {far_guess, true});
  ASSERT_TRUE(far.matched) << far.reject_reason;
  EXPECT_TRUE(far.disputed);
  EXPECT_NEAR(far.wheel_disagreement, chi2(far_guess), 0.1 * chi2(far_guess));
  EXPECT_NEAR(far.motion.x, truth.x, 0.01);  // ICP's motion is kept ...
  EXPECT_NEAR(far.motion.y, truth.y, 0.01);
  const Eigen::Vector3d d(far_guess.x - far.motion.x, far_guess.y - far.motion.y, far_guess.theta - far.motion.theta);
  EXPECT_LE(d.dot(far.covariance.inverse() * d), 1.0 + 1e-9);  // ... and the wheels' lies within one sigma

  // Wheels known to be four times noisier than modelled: 0.6 m is no dispute.
  EXPECT_FALSE(odometry.match(*first, *second, {far_guess, true, 4.0}).disputed);
  llc::ScanOdometryOptions off = hold_both;
  off.max_wheel_disagreement = 0.0;
  const llc::OdometryStep unchecked = llc::ScanOdometry(off).match(*first, *second, {far_guess, true});
  EXPECT_FALSE(unchecked.disputed);
  EXPECT_TRUE(unchecked.covariance.isApprox(odometry.stepCovariance(unchecked.motion, true)));
  // Without wheels there is nothing to disagree with.
  EXPECT_LT(odometry.match(*first, *second, {far_guess, false}).wheel_disagreement, 0.0);

  // With correlative_recovery (the default) the laser fits far better than the wheels' guess
  // 0.6 m off: ICP's motion is a matched step with a wheel step's covariance, not disputed.
  const llc::ScanOdometry recovering;
  const llc::OdometryStep recovered = recovering.match(*first, *second, {far_guess, true});
  ASSERT_TRUE(recovered.matched) << recovered.reject_reason;
  EXPECT_TRUE(recovered.recovered);
  EXPECT_FALSE(recovered.disputed);
  EXPECT_NEAR(recovered.motion.x, truth.x, 0.01);
  EXPECT_NEAR(recovered.motion.y, truth.y, 0.01);
  EXPECT_TRUE(recovered.covariance.isApprox(recovering.stepCovariance(recovered.motion, false)));
  // Near the truth the wheels are not doubted: nothing to recover.
  EXPECT_FALSE(recovering.match(*first, *second, {near_guess, true}).recovered);
}

/// FR079's wheels count a reverse as forward: the guess is 0.6 m ahead, the robot 0.6 m back.
/// ICP's result is 1.2 m from the wheels (beyond max_correction_translation), so without
/// recovery the wheels' step stands; the correlative search, centred on no motion, finds the
/// reverse, and ICP from there the exact motion.
TEST(ScanOdometry, WheelsThatCountAReverseAsForwardAreOverruledByTheLaser) {
  const llc::Pose2 truth{-0.6, 0.05, 0.1};
  const llc::Pose2 guess{0.6, 0.0, 0.1};
  const llc::ScanAligner aligner;
  const auto first = aligner.prepare(roomScan({}));
  const auto second = aligner.prepare(roomScan(truth));
  llc::ScanOdometryOptions off;
  off.correlative_recovery = false;
  const llc::OdometryStep wheels = llc::ScanOdometry(off).match(*first, *second, {guess, true});
  EXPECT_FALSE(wheels.matched);
  EXPECT_EQ(wheels.refusal, llc::OdometryRefusal::kTooFarFromWheels);
  EXPECT_NEAR(wheels.motion.x, guess.x, 1e-12);

  const llc::OdometryStep laser = llc::ScanOdometry().match(*first, *second, {guess, true});
  ASSERT_TRUE(laser.matched) << laser.reject_reason;
  EXPECT_TRUE(laser.recovered);
  EXPECT_EQ(laser.refusal, llc::OdometryRefusal::kNone);
  EXPECT_NEAR(laser.motion.x, truth.x, 0.02);
  EXPECT_NEAR(laser.motion.y, truth.y, 0.02);
  EXPECT_NEAR(laser.motion.theta, truth.theta, 0.005);
}

/// In a bare corridor every shift along it fits about alike: the laser cannot say the wheels
/// are wrong, so a guess 0.8 m too far along stays as the wheels' (unmatched or ICP's, never
/// pulled back by the search).
TEST(ScanOdometry, WhereTheLaserCannotTellTheWheelsStay) {
  const std::vector<Wall> walls = corridor();
  const llc::ScanAligner aligner;
  const auto first = aligner.prepare(corridorScan(walls, 150));  // x = 105 m: the niches out of range
  const auto second = aligner.prepare(corridorScan(walls, 151));  // 0.7 m on
  const llc::Pose2 guess{1.5, 0.1 * (std::sin(0.05 * 151) - std::sin(0.05 * 150)), 0.0};
  const llc::OdometryStep step = llc::ScanOdometry().match(*first, *second, {guess, true});
  EXPECT_FALSE(step.recovered);
  EXPECT_GT(step.motion.x, 1.1) << "the laser cannot know how far the robot went";
}

/// A corridor 2 m wide with door jambs every 3 m on both sides, 3-15 m ahead: the scans of
/// its walls fit any shift along it, and only the jambs (about 7% of the points) say how far
/// the robot went.
std::vector<Wall> doorCorridor() {
  std::vector<Wall> walls = {{-30, -1, 30, -1}, {-30, 1, 30, 1}};
  for (double x = 2.0; x <= 16.0; x += 2.0) {
    walls.push_back({x, 1, x, 0.6});
    walls.push_back({x + 1.0, -1, x + 1.0, -0.6});
  }
  return walls;
}

llc::Scan doorCorridorScan(double x) {
  const std::vector<Wall> walls = doorCorridor();
  llc::Scan scan = llc_test::ringScan(std::vector<double>(360));
  for (std::size_t i = 0; i < scan.ranges.size(); ++i) scan.ranges[i] = castRay(walls, x, 0.0, scan.bearings[i]);
  return scan;
}

TEST(ScanOdometry, ASeedFromTheLaserKeepsThePairsThatSeeAMotionAlongACorridor) {
  // The robot drove 0.3 m; the laser's seed (a velocity of 0 after a turn in place) says it
  // stood. From there the jambs' pairs are the farthest: trimmed away (icp/trim_fraction 0.9
  // drops a tenth), the walls keep the seed; kept (laser_seeded_trim_fraction), they pull ICP on.
  const llc::ScanAligner aligner;
  const auto first = aligner.prepare(doorCorridorScan(0.0));
  const auto second = aligner.prepare(doorCorridorScan(0.3));
  const llc::Pose2 stood{0.0, 0.0, 0.0};
  llc::ScanOdometryOptions trimmed;
  trimmed.laser_seeded_trim_fraction = trimmed.icp.trim_fraction;
  ASSERT_EQ(trimmed.icp.trim_fraction, 0.9);
  const llc::OdometryStep stuck = llc::ScanOdometry(trimmed).match(*first, *second, {stood, false});
  EXPECT_TRUE(!stuck.matched || stuck.motion.x < 0.15) << "with a tenth trimmed, the jambs were expected to be dropped";
  EXPECT_LT(stuck.motion.x, 0.15);
  const llc::ScanOdometryOptions defaults;
  const llc::OdometryStep step = llc::ScanOdometry(defaults).match(*first, *second, {stood, false});
  ASSERT_TRUE(step.matched) << step.reject_reason;
  EXPECT_NEAR(step.motion.x, 0.3, 0.02);
  EXPECT_NEAR(step.motion.y, 0.0, 0.02);
  // The wheels' seed keeps icp/trim_fraction (and remapping): where the wheels say 0.3 m, it stands.
  const llc::OdometryStep wheels = llc::ScanOdometry(defaults).match(*first, *second, {{0.3, 0.0, 0.0}, true});
  EXPECT_NEAR(wheels.motion.x, 0.3, 0.02);
}

/// The room of roomWalls as 360 beams see it from (x, 0), with, when `person`, someone standing
/// 0.4 m in front of its far wall: a metre of new surface the room's first scan never saw.
llc::Scan roomWithVisitorScan(double x, bool person) {
  std::vector<Wall> walls = roomWalls();
  if (person) walls.push_back({-1.0, -3.6, 0.0, -3.6});
  llc::Scan scan = llc_test::ringScan(std::vector<double>(360));
  for (std::size_t i = 0; i < scan.ranges.size(); ++i) scan.ranges[i] = castRay(walls, x, 0.0, scan.bearings[i]);
  return scan;
}

TEST(ScanOdometry, AStepFromTheLaserSeedIsPolishedWithoutThePointsNewlyInView) {
  // The new scan holds 4% of points with no counterpart (a visitor 0.4 m before the wall):
  // keeping 98% of the pairs keeps half of them, and they pull the step 2.5 mm towards them;
  // ICP again from there with a tenth trimmed drops them all and finds the step (0.07 mm).
  const llc::ScanAligner aligner;
  const auto first = aligner.prepare(roomWithVisitorScan(0.0, false));
  const auto second = aligner.prepare(roomWithVisitorScan(0.5, true));
  const llc::Pose2 predicted{0.45, 0.03, 0.01};
  llc::ScanOdometryOptions unpolished;
  unpolished.laser_seeded_polish_translation = 0.0;
  const llc::OdometryStep pulled = llc::ScanOdometry(unpolished).match(*first, *second, {predicted, false});
  ASSERT_TRUE(pulled.matched) << pulled.reject_reason;
  const double pulled_error = std::hypot(pulled.motion.x - 0.5, pulled.motion.y);
  const llc::ScanOdometryOptions defaults;
  ASSERT_GT(defaults.laser_seeded_polish_translation, 0.0);
  const llc::OdometryStep step = llc::ScanOdometry(defaults).match(*first, *second, {predicted, false});
  ASSERT_TRUE(step.matched) << step.reject_reason;
  const double error = std::hypot(step.motion.x - 0.5, step.motion.y);
  EXPECT_GT(pulled_error, 0.0015) << "the visitor was expected to pull the unpolished step";
  EXPECT_LT(error, 0.0005);
  EXPECT_LT(std::abs(step.motion.theta), 0.0005);
  // Bounded: a polish that would move farther than laser_seeded_polish_translation is not taken.
  llc::ScanOdometryOptions tight = defaults;
  tight.laser_seeded_polish_translation = 0.25 * pulled_error;
  const llc::OdometryStep kept = llc::ScanOdometry(tight).match(*first, *second, {predicted, false});
  EXPECT_NEAR(kept.motion.x, pulled.motion.x, 1e-9);
  EXPECT_NEAR(kept.motion.y, pulled.motion.y, 1e-9);
  // The wheels' seed is matched with a tenth trimmed already: nothing to polish, same step.
  const llc::OdometryStep wheels = llc::ScanOdometry(defaults).match(*first, *second, {predicted, true});
  const llc::OdometryStep wheels_unpolished = llc::ScanOdometry(unpolished).match(*first, *second, {predicted, true});
  EXPECT_EQ(wheels.motion.x, wheels_unpolished.motion.x);
  EXPECT_EQ(wheels.motion.y, wheels_unpolished.motion.y);
}

TEST(ScanOdometry, CorrelativeRecoveryOptionsAreValidated) {
  llc::ScanOdometryOptions options;
  options.correlative.translation_step = 0.0;
  EXPECT_NE(options.validate().find("correlative: translation_step"), std::string::npos);
  EXPECT_THROW(llc::ScanOdometry{options}, std::invalid_argument);
  options = {};
  options.realign_below_overlap = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(options.validate().find("realign_below_overlap must be in [0, 1]"), std::string::npos);
  options.realign_below_overlap = 0.0;  // off
  EXPECT_EQ(options.validate(), "");
  options = {};
  for (double bad : {0.0, 1.01, std::numeric_limits<double>::quiet_NaN()}) {
    options.laser_seeded_trim_fraction = bad;
    EXPECT_NE(options.validate().find("laser_seeded_trim_fraction must be in (0, 1]"), std::string::npos) << bad;
  }
  options.laser_seeded_trim_fraction = 1.0;
  EXPECT_EQ(options.validate(), "");
  for (double bad : {-0.01, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    options = {};
    options.laser_seeded_polish_translation = bad;
    EXPECT_NE(options.validate().find("laser_seeded_polish_translation and laser_seeded_polish_rotation must be finite and >= 0"),
              std::string::npos) << bad;
    options = {};
    options.laser_seeded_polish_rotation = bad;
    EXPECT_NE(options.validate().find("laser_seeded_polish_rotation must be finite"), std::string::npos) << bad;
  }
  options = {};
  options.laser_seeded_polish_translation = 0.0;  // off
  EXPECT_EQ(options.validate(), "");
}

TEST(WheelNoiseScale, IsUnknownUntilTwentyStepsThenTheMedianOverTheChiSquareMedianAtLeastOne) {
  llc::WheelNoiseScale scale(100);
  for (int i = 0; i < 19; ++i) scale.add(2.366 * 3.0);
  EXPECT_TRUE(std::isinf(scale.scale()));
  scale.add(2.366 * 3.0);
  EXPECT_NEAR(scale.scale(), 3.0, 1e-9);
  scale.add(-1.0);  // no comparison: ignored
  scale.add(std::numeric_limits<double>::quiet_NaN());
  EXPECT_NEAR(scale.scale(), 3.0, 1e-9);

  llc::WheelNoiseScale quiet(100);
  for (int i = 0; i < 50; ++i) quiet.add(0.1);
  EXPECT_DOUBLE_EQ(quiet.scale(), 1.0);  // quieter than modelled: the model stays
  // Only the last 100 count: 100 large values push out the 50 small ones.
  for (int i = 0; i < 100; ++i) quiet.add(2.366 * 10.0);
  EXPECT_NEAR(quiet.scale(), 10.0, 1e-9);
}

TEST(ScanOdometry, WheelDisagreementOptionsAreValidated) {
  llc::ScanOdometryOptions options;
  options.max_wheel_disagreement = -1.0;
  EXPECT_NE(options.validate().find("max_wheel_disagreement"), std::string::npos);
  options = {};
  options.wheel_noise_window = 5;
  EXPECT_NE(options.validate().find("wheel_noise_window"), std::string::npos);
  EXPECT_THROW(llc::ScanOdometry{options}, std::invalid_argument);
}

TEST(OdometryPriorGate, TestsALoopAgainstTheChainAsTheBackEndWould) {
  // Keyframes at scans 0, 10, 20, 1 m apart along x; each step sigma 0.1 m, heading all but exact.
  std::vector<llc::Pose2> odometry;
  for (int i = 0; i <= 20; ++i) odometry.push_back({0.1 * i, 0.0, 0.0});
  llc::OdometryStep step;
  step.motion = {1.0, 0.0, 0.0};
  step.covariance = Eigen::Vector3d(0.01, 0.01, 1e-10).asDiagonal();
  const std::vector<llc::OdometryStep> steps(3, step);
  llc::OdometryPriorGate gate(odometry, {0, 10, 20}, steps);
  EXPECT_EQ(gate.keyframes(), 3u);
  const Eigen::Matrix3d loop_covariance = Eigen::Vector3d(0.01, 0.01, 1e-10).asDiagonal();
  // The chain predicts 2 m from scan 0 to scan 20: a loop saying so has no innovation ...
  EXPECT_NEAR(gate.chi2(0, 20, {2.0, 0.0, 0.0}, loop_covariance), 0.0, 1e-6);
  // ... 0.3 m more: 0.09 / (0.01 + 0.01 + 0.01) = 3 (two steps and the loop).
  EXPECT_NEAR(gate.chi2(0, 20, {2.3, 0.0, 0.0}, loop_covariance), 3.0, 1e-3);
  EXPECT_FALSE(gate.refuses(0, 20, {2.3, 0.0, 0.0}, loop_covariance));
  EXPECT_TRUE(gate.refuses(0, 20, {3.0, 0.0, 0.0}, loop_covariance));  // 1 / 0.03 = 33 > 16.27
  // Scan 5 lies 0.5 m past keyframe 0 by the wheels: 1.5 m on from it is the same prediction.
  EXPECT_NEAR(gate.chi2(5, 20, {1.5, 0.0, 0.0}, loop_covariance), 0.0, 1e-6);
  // Within one keyframe only the loop is uncertain: 0.2 m off is 0.04 / 0.01 = 4.
  EXPECT_NEAR(gate.chi2(2, 7, {0.7, 0.0, 0.0}, loop_covariance), 4.0, 1e-6);
  EXPECT_THROW(gate.chi2(20, 0, {}, loop_covariance), std::invalid_argument);
  EXPECT_THROW(gate.chi2(0, 21, {}, loop_covariance), std::out_of_range);
  EXPECT_THROW(llc::OdometryPriorGate(odometry, {0, 10}, steps), std::invalid_argument);
  EXPECT_THROW(llc::OdometryPriorGate(odometry, {0, 10, 10}, steps), std::invalid_argument);
  EXPECT_THROW(llc::OdometryPriorGate(odometry, {0, 10, 30}, steps), std::invalid_argument);
}

TEST(OdometryPriorGate, BuiltByTheFrontEndItPassesTheTrueLoopAndRefusesAShiftedOne) {
  // A room driven along x at 0.25 m per scan, the wheels exact: ICP keyframe steps.
  std::vector<llc::Scan> scans;
  std::vector<llc::Pose2> odometry;
  for (int i = 0; i <= 16; ++i) {
    odometry.push_back({-2.0 + 0.25 * i, 0.5, 0.0});
    scans.push_back(roomScan(odometry.back()));
    scans.back().stamp = 0.1 * i;
  }
  llc::OdometryPriorGate gate = llc::OdometryPriorGate::fromFrontEnd(
      scans, odometry, llc::ScanOdometryOptions{}, llc::ScanAlignerOptions{}, llc_test::defaultModel().features);
  EXPECT_EQ(gate.keyframes(), 5u);  // every 1 m: scans 0, 4, 8, 12, 16
  const Eigen::Matrix3d loop_covariance = Eigen::Vector3d(0.0025, 0.0025, 1e-4).asDiagonal();
  EXPECT_FALSE(gate.refuses(0, 16, {4.0, 0.0, 0.0}, loop_covariance));
  EXPECT_TRUE(gate.refuses(0, 16, {7.0, 0.0, 0.0}, loop_covariance));
}

TEST(ScanOdometry, WheelOdometryThatJumpsFasterThanAnyRobotIsLeftOut) {
  // Across the room at 1 m/s, a scan every 0.1 s; the wheels are exact but for a one-scan spike
  // of 1e9 m at scan 20 and, from scan 50 on, a jump of 1e9 m with the heading flipped.
  llc::SlamFrontEnd front(llc_test::defaultModel(), llc::ScanOdometryOptions{}, llc::ScanAlignerOptions{},
                          llc::LoopDetectorOptions{});
  llc::Pose2 chain, truth_last_keyframe;
  std::size_t keyframes = 0, jumps_said = 0;
  for (int i = 0; i <= 80; ++i) {
    const llc::Pose2 truth{-4.0 + 0.1 * i, 0.5, 0.0};
    llc::Scan scan = roomScan(truth);
    scan.stamp = 0.1 * i;
    llc::Pose2 wheels = truth;
    if (i == 20) wheels.x += 1e9;
    if (i >= 50) wheels = llc::compose({1e9, -3.0, M_PI}, truth);
    const llc::FrontEndStep step = front.addScan(scan, &wheels);
    ASSERT_TRUE(step.skip_reason.empty()) << step.skip_reason;
    jumps_said += !step.wheel_jump.empty();
    if (!step.keyframe) continue;
    if (keyframes++ > 0) chain = llc::compose(chain, step.odometry.motion);
    ASSERT_TRUE(llc::isFinite(step.odometry.motion));
    truth_last_keyframe = truth;
  }
  EXPECT_EQ(front.counters().wheel_jumps, 3u);  // the spike up, back down, and the step
  EXPECT_EQ(jumps_said, 3u);
  EXPECT_GE(keyframes, 7u);
  // The chain from the first keyframe (at x = -4) ends where the robot did.
  EXPECT_NEAR(chain.x, truth_last_keyframe.x + 4.0, 0.1);
  EXPECT_NEAR(chain.y, 0.0, 0.1);
  EXPECT_NEAR(chain.theta, 0.0, 0.02);
}

TEST(ScanOdometry, StampsMilliSecondsApartDoNotMakeAVelocity) {
  // Without wheels, scans of a log can be 0.5 ms apart: a velocity from them would be 200x the
  // robot's and throw the next prediction far off. Every other scan comes 0.5 ms after the one
  // before (and the motion still shows between them, as the scans were not taken then).
  llc::SlamFrontEnd front(llc_test::defaultModel(), llc::ScanOdometryOptions{}, llc::ScanAlignerOptions{},
                          llc::LoopDetectorOptions{});
  llc::Pose2 chain, truth_last_keyframe;
  std::size_t keyframes = 0;
  double stamp = 0.0;
  for (int i = 0; i <= 60; ++i) {
    const llc::Pose2 truth{-3.0 + 0.1 * i, 0.5, 0.0};
    llc::Scan scan = roomScan(truth);
    stamp += (i % 2) ? 0.0005 : 0.2;
    scan.stamp = stamp;
    const llc::FrontEndStep step = front.addScan(scan, nullptr);
    ASSERT_TRUE(step.skip_reason.empty()) << step.skip_reason;
    if (!step.keyframe) continue;
    if (keyframes++ > 0) chain = llc::compose(chain, step.odometry.motion);
    truth_last_keyframe = truth;
  }
  EXPECT_GE(keyframes, 5u);
  EXPECT_NEAR(chain.x, truth_last_keyframe.x + 3.0, 0.2);
  EXPECT_NEAR(chain.y, 0.0, 0.2);
}

TEST(ScanOdometry, SpeedLimitsAreValidated) {
  llc::ScanOdometryOptions options;
  options.max_speed = 0.0;
  EXPECT_NE(options.validate().find("max_speed"), std::string::npos);
  options = {};
  options.min_velocity_interval = -1.0;
  EXPECT_NE(options.validate().find("min_velocity_interval"), std::string::npos);
}

TEST(ScanOdometry, StampsThatJumpBackStartANewChainAndSlightlyOlderOnesAreSkipped) {
  // Across the room twice, as a bag played in a loop: the second pass has the first's stamps
  // and wheel odometry again.
  llc::SlamFrontEnd front(llc_test::defaultModel(), llc::ScanOdometryOptions{}, llc::ScanAlignerOptions{},
                          llc::LoopDetectorOptions{});
  std::size_t keyframes_second_pass = 0, time_jumps_said = 0;
  llc::FrontEndStep first_of_second_pass;
  for (int pass = 0; pass < 2; ++pass)
    for (int i = 0; i <= 60; ++i) {
      const llc::Pose2 truth{-3.0 + 0.1 * i, 0.5, 0.0};
      llc::Scan scan = roomScan(truth);
      scan.stamp = 100.0 + 0.1 * i;
      const llc::FrontEndStep step = front.addScan(scan, &truth);
      ASSERT_TRUE(step.skip_reason.empty()) << "pass " << pass << " scan " << i << ": " << step.skip_reason;
      time_jumps_said += !step.time_jump.empty();
      if (pass == 1 && step.keyframe && keyframes_second_pass++ == 0) first_of_second_pass = step;
    }
  EXPECT_EQ(front.counters().time_jumps, 1u);
  EXPECT_EQ(time_jumps_said, 1u);
  EXPECT_GE(keyframes_second_pass, 6u);  // mapping goes on (before: every scan skipped)
  EXPECT_NE(first_of_second_pass.odometry.reject_reason.find("time jumped back"), std::string::npos);
  EXPECT_TRUE(first_of_second_pass.odometry.covariance.isApprox(llc::SlamFrontEnd::restartCovariance()));

  // 0.5 s older than the newest keyframe: out of order, skipped; no new chain.
  llc::Scan late = roomScan({3.0, 0.5, 0.0});
  late.stamp = 100.0 + 6.0 - 0.5;
  const llc::Pose2 wheels{3.0, 0.5, 0.0};
  EXPECT_EQ(front.addScan(late, &wheels).skip_reason, "time went backwards");
  EXPECT_EQ(front.counters().time_jumps, 1u);
}

}  // namespace

namespace {


}  // namespace
