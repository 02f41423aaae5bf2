// Odometry drift for real logs: hand-worked scale and heading drift, seeded noise, truth kept.
#include <gtest/gtest.h>

#include <cmath>

#include "laser_loop_closure/core/sim/odometry_drift.hpp"

namespace {

llc::OdometryDrift noNoise() {
  llc::OdometryDrift d;
  d.scale_bias = 0.0, d.heading_drift = 0.0, d.noise_translation = 0.0, d.noise_rotation = 0.0, d.noise_fraction = 0.0;
  return d;
}

std::vector<llc::Pose2> straightLine(int steps, double step_m) {
  std::vector<llc::Pose2> poses;
  for (int k = 0; k <= steps; ++k) poses.push_back({2.0 + k * step_m, -1.0, 0.0});
  return poses;
}

TEST(OdometryDrift, WithNothingToAddTheOdometryStaysAsItWas) {
  const std::vector<llc::Pose2> odometry = {{0, 0, 0}, {1, 0.5, 0.3}, {1.5, 1.5, 1.2}, {0.5, 2.0, 2.9}};
  const std::vector<llc::Pose2> same = llc::driftOdometry(odometry, noNoise());
  ASSERT_EQ(same.size(), odometry.size());
  for (std::size_t k = 0; k < odometry.size(); ++k) {
    EXPECT_NEAR(same[k].x, odometry[k].x, 1e-12);
    EXPECT_NEAR(same[k].y, odometry[k].y, 1e-12);
    EXPECT_NEAR(same[k].theta, odometry[k].theta, 1e-12);
  }
}

TEST(OdometryDrift, ScaleBiasLengthensEveryStep) {
  llc::OdometryDrift d = noNoise();
  d.scale_bias = 0.1;
  const std::vector<llc::Pose2> drifted = llc::driftOdometry(straightLine(10, 0.5), d);
  EXPECT_DOUBLE_EQ(drifted.front().x, 2.0);  // the first pose is kept
  EXPECT_NEAR(drifted.back().x, 2.0 + 10 * 0.55, 1e-12);
  EXPECT_NEAR(drifted.back().y, -1.0, 1e-12);
}

TEST(OdometryDrift, HeadingDriftTurnsByItsRatePerMetre) {
  llc::OdometryDrift d = noNoise();
  d.heading_drift = 0.01;  // rad per metre
  const std::vector<llc::Pose2> drifted = llc::driftOdometry(straightLine(20, 0.5), d);
  EXPECT_NEAR(drifted.back().theta, 20 * 0.5 * 0.01, 1e-12);  // 10 m driven: 0.1 rad
  // Each 0.5 m step is taken along the heading reached so far: the path bends to the left.
  double x = 2.0, y = -1.0, theta = 0.0;
  for (int k = 0; k < 20; ++k) {
    x += 0.5 * std::cos(theta), y += 0.5 * std::sin(theta);
    theta += 0.005;
  }
  EXPECT_NEAR(drifted.back().x, x, 1e-12);
  EXPECT_NEAR(drifted.back().y, y, 1e-12);
}

TEST(OdometryDrift, NoiseIsSeeded) {
  llc::OdometryDrift d;  // the defaults: bias, drift and noise
  const std::vector<llc::Pose2> line = straightLine(200, 0.1);
  const std::vector<llc::Pose2> a = llc::driftOdometry(line, d), b = llc::driftOdometry(line, d);
  d.seed = 2;
  const std::vector<llc::Pose2> c = llc::driftOdometry(line, d);
  EXPECT_EQ(a.back().x, b.back().x);
  EXPECT_EQ(a.back().theta, b.back().theta);
  EXPECT_NE(a.back().x, c.back().x);
  // 20 m at 1.5% bias and 0.005 rad/m drift: about 20.3 m along, and bent; noise keeps it near.
  EXPECT_NEAR(std::hypot(a.back().x - 2.0, a.back().y + 1.0), 20.3, 1.0);
}

TEST(OdometryDrift, TheTruthOfASequenceStays) {
  llc::ScanSequence sequence;
  for (const llc::Pose2& p : straightLine(30, 0.3)) {
    llc::LoggedScan s;
    s.truth = p;
    s.odometry = p;
    sequence.scans.push_back(s);
  }
  llc::driftOdometry(&sequence, llc::OdometryDrift{});
  EXPECT_DOUBLE_EQ(sequence.scans.back().truth.x, 2.0 + 30 * 0.3);
  EXPECT_DOUBLE_EQ(sequence.scans.back().truth.y, -1.0);
  EXPECT_GT(std::hypot(sequence.scans.back().odometry.x - sequence.scans.back().truth.x,
                       sequence.scans.back().odometry.y - sequence.scans.back().truth.y),
            1e-3)
      << "the odometry must have drifted";
  sequence.has_odometry = false;
  EXPECT_THROW(llc::driftOdometry(&sequence, llc::OdometryDrift{}), std::invalid_argument);
}

TEST(OdometryDrift, BadOptionsAreRefused) {
  llc::OdometryDrift d;
  d.noise_translation = -0.1;
  EXPECT_NE(d.validate(), "");
  EXPECT_THROW(llc::driftOdometry(straightLine(3, 1.0), d), std::invalid_argument);
  d = llc::OdometryDrift{};
  d.scale_bias = -1.0;
  EXPECT_NE(d.validate(), "");
  d = llc::OdometryDrift{};
  d.heading_drift = std::nan("");
  EXPECT_NE(d.validate(), "");
  EXPECT_EQ(llc::OdometryDrift{}.validate(), "");
}

}  // namespace
