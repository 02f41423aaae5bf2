// The adapter's conversions, with no master.
#include <gtest/gtest.h>
#include <ros/serialization.h>

#include <cmath>
#include <limits>

#include "laser_loop_closure/ros/io/msg_conversion.hpp"

namespace {

sensor_msgs::LaserScan makeScan(std::size_t n) {
  sensor_msgs::LaserScan msg;
  msg.angle_min = -M_PI / 2;
  msg.angle_increment = M_PI / double(n - 1);
  msg.angle_max = M_PI / 2;
  msg.range_min = 0.1f;
  msg.range_max = 30.0f;
  msg.ranges.assign(n, 5.0f);
  msg.header.stamp.fromSec(12.5);
  return msg;
}

TEST(MsgConversion, LaserScanKeepsGeometryAndMapsRep117) {
  sensor_msgs::LaserScan msg = makeScan(5);
  msg.ranges = {5.0f, 40.0f, std::numeric_limits<float>::quiet_NaN(), 0.05f, 2.0f};
  llc::Scan scan;
  std::string error;
  ASSERT_TRUE(llc_ros::toScan(msg, llc::Pose2{}, &scan, &error)) << error;
  ASSERT_EQ(scan.size(), 5u);
  EXPECT_NEAR(scan.bearings[0], -M_PI / 2, 1e-6);
  EXPECT_NEAR(scan.bearings[4], M_PI / 2, 1e-6);
  EXPECT_DOUBLE_EQ(scan.ranges[0], 5.0);
  EXPECT_TRUE(std::isinf(scan.ranges[1]) && scan.ranges[1] > 0);  // beyond range_max: no return
  EXPECT_TRUE(std::isnan(scan.ranges[2]));
  EXPECT_TRUE(std::isinf(scan.ranges[3]) && scan.ranges[3] < 0);  // below range_min: too close
  EXPECT_DOUBLE_EQ(scan.stamp, 12.5);
}

TEST(MsgConversion, RefusesMalformedScans) {
  llc::Scan scan;
  std::string error;
  sensor_msgs::LaserScan msg = makeScan(5);
  msg.angle_increment = 0.0f;
  EXPECT_FALSE(llc_ros::toScan(msg, llc::Pose2{}, &scan, &error));
  EXPECT_FALSE(error.empty());
  msg = makeScan(5);
  msg.ranges.resize(50);  // resized without new angles
  EXPECT_FALSE(llc_ros::toScan(msg, llc::Pose2{}, &scan, &error));
  msg = makeScan(5);
  msg.angle_min = std::numeric_limits<float>::infinity();
  EXPECT_FALSE(llc_ros::toScan(msg, llc::Pose2{}, &scan, &error));
}

TEST(MsgConversion, MountedScannerPointsLandInBaseFrame) {
  sensor_msgs::LaserScan msg = makeScan(3);  // beams at -90, 0, +90 degrees
  llc::Scan scan;
  std::string error;
  // A rear scanner 0.5 m behind the base, facing backwards: its 0-degree beam points along -x.
  ASSERT_TRUE(llc_ros::toScan(msg, llc::Pose2{-0.5, 0.0, M_PI}, &scan, &error)) << error;
  bool found = false;
  for (std::size_t i = 0; i < scan.size(); ++i)
    if (std::abs(std::abs(scan.bearings[i]) - M_PI) < 1e-6) {
      EXPECT_NEAR(scan.ranges[i], 5.5, 1e-5);
      found = true;
    }
  EXPECT_TRUE(found);
}

TEST(MsgConversion, Scan360RoundTrip) {
  llc::Scan scan;
  scan.ranges = {1.0, std::numeric_limits<double>::infinity(), 3.0};
  scan.bearings = {-1.0, 0.0, 1.0};
  scan.full_circle = true;
  std_msgs::Header header;
  header.stamp.fromSec(3.0);
  header.frame_id = "base_link";
  llc::Scan back;
  std::string error;
  ASSERT_TRUE(llc_ros::fromScan360(llc_ros::toScan360(scan, header), &back, &error));
  EXPECT_EQ(back.ranges.size(), 3u);
  EXPECT_TRUE(std::isinf(back.ranges[1]));
  EXPECT_FLOAT_EQ(back.bearings[2], 1.0f);
  EXPECT_TRUE(back.full_circle);
  laser_loop_closure::Scan360 bad = llc_ros::toScan360(scan, header);
  bad.bearings.pop_back();
  EXPECT_FALSE(llc_ros::fromScan360(bad, &back, &error));
}

TEST(MsgConversion, KeyframeAndLoopClosureRoundTrip) {
  llc::Keyframe keyframe;
  keyframe.scan_index = 17;
  keyframe.stamp = 12.5;
  keyframe.scan.ranges = {1.0, 2.0};
  keyframe.scan.bearings = {-0.5, 0.5};
  keyframe.has_wheel_odometry = true;
  keyframe.wheel_odometry = {1.0, -2.0, 0.3};
  llc::OdometryStep step;
  step.motion = {0.9, 0.1, -0.2};
  step.covariance << 0.01, 0.002, 0.0, 0.002, 0.02, 0.001, 0.0, 0.001, 0.003;
  step.matched = true;
  const laser_loop_closure::Keyframe msg = llc_ros::toKeyframeMsg(keyframe, 4, step, "base_link");
  EXPECT_EQ(msg.index, 4u);
  EXPECT_EQ(msg.motion_covariance[1], 0.002);  // row-major: (0, 1)
  EXPECT_EQ(msg.motion_covariance[5], 0.001);  // (1, 2)
  llc::Keyframe back;
  llc::Pose2 motion;
  Eigen::Matrix3d covariance;
  std::string error;
  ASSERT_TRUE(llc_ros::fromKeyframeMsg(msg, &back, &motion, &covariance, &error)) << error;
  EXPECT_EQ(back.scan_index, 17u);
  EXPECT_DOUBLE_EQ(back.stamp, 12.5);
  EXPECT_DOUBLE_EQ(back.wheel_odometry.theta, 0.3);
  EXPECT_DOUBLE_EQ(motion.x, 0.9);
  EXPECT_TRUE(covariance.isApprox(step.covariance, 0.0));
  // Non-finite odometry is passed on for the back end to replace (the keyframe is kept) ...
  laser_loop_closure::Keyframe bad = msg;
  bad.motion.theta = std::numeric_limits<double>::quiet_NaN();
  bad.wheel_odometry.x = std::numeric_limits<double>::infinity();
  ASSERT_TRUE(llc_ros::fromKeyframeMsg(bad, &back, &motion, &covariance, &error)) << error;
  EXPECT_TRUE(std::isnan(motion.theta));
  EXPECT_TRUE(std::isinf(back.wheel_odometry.x));
  // ... a malformed scan is not.
  bad = msg;
  bad.scan.bearings.pop_back();
  EXPECT_FALSE(llc_ros::fromKeyframeMsg(bad, &back, &motion, &covariance, &error));
  EXPECT_FALSE(error.empty());
  // Packed for a network: every field back, the scan within the packing's steps, the step and
  // its covariance to float32, no features; a corrupt packing refused.
  laser_loop_closure::Keyframe full_msg = msg;
  full_msg.features = {1.0, 2.0};
  full_msg.loops_before = 6;
  llc::Scan full = keyframe.scan;
  full.full_circle = true;
  const laser_loop_closure::PackedKeyframe packed = llc_ros::packKeyframeMsg(full_msg, full, llc::ScanPackOptions{});
  // Fixed fields: 8 stamp, 4 + 4 + 8 numbers, 2 flags, 24 wheels, 12 motion, 24 covariance, 4 the scan's length.
  EXPECT_EQ(ros::serialization::serializationLength(packed), 90u + packed.scan.size());
  laser_loop_closure::Keyframe unpacked;
  ASSERT_TRUE(llc_ros::unpackKeyframeMsg(packed, &unpacked, &error)) << error;
  EXPECT_TRUE(unpacked.features.empty());
  EXPECT_EQ(unpacked.index, 4u);
  EXPECT_EQ(unpacked.loops_before, 6u);
  EXPECT_TRUE(unpacked.scan_matched);
  ASSERT_TRUE(llc_ros::fromKeyframeMsg(unpacked, &back, &motion, &covariance, &error)) << error;
  ASSERT_EQ(back.scan.size(), 2u);
  EXPECT_NEAR(back.scan.ranges[1], 2.0, 0.0025);
  EXPECT_NEAR(back.scan.bearings[0], -0.5, 5e-5);
  EXPECT_TRUE(back.scan.full_circle);
  EXPECT_DOUBLE_EQ(back.scan.stamp, 12.5);
  EXPECT_EQ(back.scan_index, 17u);
  EXPECT_TRUE(back.has_wheel_odometry);
  EXPECT_DOUBLE_EQ(back.wheel_odometry.y, -2.0);  // float64: a pose far from the odometry origin keeps its millimetres
  EXPECT_NEAR(motion.x, 0.9, 1e-7);
  EXPECT_NEAR(motion.theta, -0.2, 1e-7);
  EXPECT_TRUE(covariance.isApprox(step.covariance, 1e-6)) << covariance;
  EXPECT_EQ(covariance(2, 1), covariance(1, 2));  // symmetric from the upper triangle
  llc::ScanPackOptions every_other;
  every_other.beam_stride = 2;  // the first of the two
  ASSERT_TRUE(llc_ros::unpackKeyframeMsg(llc_ros::packKeyframeMsg(full_msg, full, every_other), &unpacked, &error)) << error;
  ASSERT_EQ(unpacked.scan.ranges.size(), 1u);
  EXPECT_NEAR(unpacked.scan.bearings[0], -0.5, 5e-5);
  laser_loop_closure::PackedKeyframe cut = packed;
  cut.scan.resize(cut.scan.size() - 3);
  EXPECT_FALSE(llc_ros::unpackKeyframeMsg(cut, &unpacked, &error));
  EXPECT_NE(error.find("packed scan"), std::string::npos) << error;

  llc::LoopClosure loop;
  loop.from = 3, loop.to = 40, loop.score = 0.7, loop.pose = {0.5, -0.25, 3.0}, loop.inlier_share = 0.95;
  loop.covariance = step.covariance;
  loop.accepted = true;
  std_msgs::Header header;
  const llc::LoopClosure loop_back = llc_ros::fromLoopClosureMsg(llc_ros::toLoopClosureMsg(loop, header));
  EXPECT_EQ(loop_back.from, 3u);
  EXPECT_EQ(loop_back.to, 40u);
  EXPECT_DOUBLE_EQ(loop_back.pose.theta, 3.0);
  EXPECT_TRUE(loop_back.covariance.isApprox(loop.covariance, 0.0));
  llc::LoopRecord record;
  record.loop = loop;
  record.applied = false;
  record.reject_reason = "backend: gate";
  record.innovation_chi2 = 42.0;
  const laser_loop_closure::LoopClosure as_met = llc_ros::toLoopClosureMsg(record, header);
  EXPECT_FALSE(as_met.accepted);  // on ~loop_records, accepted means applied
  EXPECT_EQ(as_met.innovation_chi2, 42.0);
}

TEST(MsgConversion, ResampledScanAsLaserScanOfConstantSize) {
  llc::Scan front;
  front.ranges = {1.0, std::numeric_limits<double>::quiet_NaN(), 2.0};
  front.bearings = {-0.1, 0.0, 0.1};
  llc::ScanMergeOptions resample;
  resample.output_beams = 360;
  std_msgs::Header header;
  const sensor_msgs::LaserScan msg = llc_ros::toLaserScan(llc::mergeScans(front, llc::Scan{}, resample), header, 0.1f, 30.0f);
  ASSERT_EQ(msg.ranges.size(), 360u);
  EXPECT_NEAR(msg.angle_increment, 2.0 * M_PI / 360.0, 1e-6);
  EXPECT_NEAR(msg.angle_min + 359 * msg.angle_increment, msg.angle_max, 1e-5);
  std::size_t finite = 0;
  for (float r : msg.ranges) finite += std::isfinite(r);
  EXPECT_EQ(finite, 2u);  // everything else +inf (REP-117: nothing returned)
  EXPECT_TRUE(std::isinf(msg.ranges[0]) && msg.ranges[0] > 0);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
