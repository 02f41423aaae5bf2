// Scanner mountings from tf: frame ids spelt the tf1 way ("/laser") and a bag or robot whose tf
// never tells a scanner's mounting; wheel odometry from tf, the same whenever it is asked.
#include <gtest/gtest.h>

#include <geometry_msgs/TransformStamped.h>
#include <tf2_ros/buffer.h>

#include <cmath>
#include <string>
#include <vector>

#include "laser_loop_closure/ros/io/tf_bridge.hpp"

namespace {

geometry_msgs::TransformStamped mounting(const std::string& parent, const std::string& child, double x, double yaw) {
  geometry_msgs::TransformStamped t;
  t.header.frame_id = parent;
  t.child_frame_id = child;
  t.transform.translation.x = x;
  t.transform.rotation.z = std::sin(yaw / 2.0);
  t.transform.rotation.w = std::cos(yaw / 2.0);
  return t;
}

TEST(TfBridge, FrameIdsLoseTf1sLeadingSlashes) {
  EXPECT_EQ(llc_ros::tfFrame("/laser"), "laser");
  EXPECT_EQ(llc_ros::tfFrame("//base_link"), "base_link");
  EXPECT_EQ(llc_ros::tfFrame("laser"), "laser");
  EXPECT_EQ(llc_ros::tfFrame("/"), "");
  EXPECT_EQ(llc_ros::tfFrame("robot/laser"), "robot/laser");
}

TEST(TfBridge, AMountingIsFoundWithOrWithoutTheLeadingSlash) {
  tf2_ros::Buffer buffer;
  buffer.setTransform(mounting("base_link", "laser", 0.3, 0.5), "test", true);
  llc_ros::MountCache mounts(buffer, "/base_link");
  EXPECT_EQ(mounts.baseFrame(), "base_link");
  llc_ros::ScannerMount mount;
  std::string error;
  ASSERT_TRUE(mounts.lookup("/laser", &mount, &error)) << error;
  EXPECT_NEAR(mount.pose.x, 0.3, 1e-9);
  EXPECT_NEAR(mount.pose.theta, 0.5, 1e-9);
  ASSERT_TRUE(mounts.lookup("laser", &mount, &error)) << error;
  EXPECT_NEAR(mount.pose.x, 0.3, 1e-9);
  // The base itself needs no tf, however it is spelt.
  ASSERT_TRUE(mounts.lookup("/base_link", &mount, &error)) << error;
  EXPECT_EQ(mount.pose.x, 0.0);
  EXPECT_FALSE(mounts.lookup("", &mount, &error));
  EXPECT_NE(error.find("no frame_id"), std::string::npos);
  EXPECT_EQ(mounts.fallbacks(), 0u);
}

TEST(TfBridge, AFrameTfNeverMountsGetsTheFallbackMountOnceAfterTheWait) {
  tf2_ros::Buffer buffer;  // no /tf at all, as in a bag of one /scan
  llc_ros::MountCache mounts(buffer, "base_link", llc_ros::FallbackMount{{0.1, -0.2, 3.0}, 3});
  llc_ros::ScannerMount mount;
  std::string error;
  bool fell_back = false;
  for (int k = 0; k < 2; ++k) {
    EXPECT_FALSE(mounts.lookup("/laser", &mount, &error, &fell_back)) << "scan " << k;
    EXPECT_NE(error.find("no mounting of scanner frame 'laser'"), std::string::npos) << error;
    EXPECT_FALSE(fell_back);
  }
  ASSERT_TRUE(mounts.lookup("/laser", &mount, &error, &fell_back));  // the third scan
  EXPECT_TRUE(fell_back);
  EXPECT_NEAR(mount.pose.x, 0.1, 1e-12);
  EXPECT_NEAR(mount.pose.y, -0.2, 1e-12);
  EXPECT_NEAR(mount.pose.theta, 3.0, 1e-12);
  fell_back = false;
  ASSERT_TRUE(mounts.lookup("laser", &mount, &error, &fell_back));  // kept: said once
  EXPECT_FALSE(fell_back);
  EXPECT_EQ(mounts.fallbacks(), 1u);
  // Without a fallback, tf is waited for as long as it takes.
  llc_ros::MountCache patient(buffer, "base_link");
  for (int k = 0; k < 50; ++k) EXPECT_FALSE(patient.lookup("laser", &mount, &error));
  EXPECT_EQ(patient.fallbacks(), 0u);
}

}  // namespace

namespace {

geometry_msgs::TransformStamped odometryAt(const ros::Time& stamp, double x, double y, double qz, double qw) {
  geometry_msgs::TransformStamped t;
  t.header.frame_id = "odom";
  t.header.stamp = stamp;
  t.child_frame_id = "base_link";
  t.transform.translation.x = x;
  t.transform.translation.y = y;
  t.transform.rotation.z = qz;
  t.transform.rotation.w = qw;
  return t;
}

// MIT CSAIL's bag: the odometry of keyframe 57's scan (its stamp has a transform of its own)
// and of the samples on either side, as the bag holds them.
const ros::Time kScanStamp(1134864686, 227514029);
std::vector<geometry_msgs::TransformStamped> mitCsailOdometry() {
  return {odometryAt(ros::Time(1134864686, 16221046), 577.274731, 4.587721, -0.4171230243706797, 0.908850033030674),
          odometryAt(kScanStamp, 577.37495, 4.428221, -0.6119236606319478, 0.7909168309998194),
          odometryAt(ros::Time(1134864686, 436383963), 577.42918, 4.257658, -0.7036305246611579, 0.7105660312490765)};
}

}  // namespace

TEST(TfBridge, WheelOdometryAtAStampIsTheSameWhetherOrNotANewerTransformHasCome) {
  const auto samples = mitCsailOdometry();
  tf2_ros::Buffer before_newer, after_newer;
  before_newer.setTransform(samples[0], "test");
  before_newer.setTransform(samples[1], "test");
  for (const auto& t : samples) after_newer.setTransform(t, "test");
  llc::Pose2 raw_before, raw_after;
  std::string error;
  ASSERT_TRUE(llc_ros::lookupPose2(before_newer, "odom", "base_link", kScanStamp, &raw_before, &error)) << error;
  ASSERT_TRUE(llc_ros::lookupPose2(after_newer, "odom", "base_link", kScanStamp, &raw_after, &error)) << error;
  // tf itself: the transform as stored, then slerped to at ratio 0 (what made the nodelets'
  // loops depend on the play rate). Should tf ever answer both alike, this still holds.
  EXPECT_NEAR(raw_before.theta, raw_after.theta, 1e-15);
  const llc::Pose2 before = llc_ros::canonicalWheelPose(raw_before), after = llc_ros::canonicalWheelPose(raw_after);
  EXPECT_EQ(before.x, after.x);
  EXPECT_EQ(before.y, after.y);
  EXPECT_EQ(before.theta, after.theta);
  EXPECT_NEAR(before.theta, -1.316981, 1e-9);
}

TEST(TfBridge, TheCanonicalWheelPoseMovesNoValueByMoreThanHalfANanometre) {
  for (const llc::Pose2& pose : {llc::Pose2{577.37495, 4.428221, -1.316981}, llc::Pose2{-1e6 / 3.0, 0.1 + 0.2, M_PI},
                                 llc::Pose2{0.0, -0.0, -M_PI}, llc::Pose2{1.23456789012e-3, 9e5 + 1e-10, 3.14159265}}) {
    const llc::Pose2 snapped = llc_ros::canonicalWheelPose(pose);
    EXPECT_LE(std::abs(snapped.x - pose.x), 5e-10 + 1e-12);
    EXPECT_LE(std::abs(snapped.y - pose.y), 5e-10 + 1e-12);
    EXPECT_LE(std::abs(llc::normalizeAngle(snapped.theta - pose.theta)), 5e-10 + 1e-12);
    EXPECT_LE(std::abs(snapped.theta), M_PI + 5e-10);
    // On the grid: snapping again changes nothing (the heading away from +-pi, where it wraps),
    // and a last-bit neighbour lands there too.
    const llc::Pose2 again = llc_ros::canonicalWheelPose(snapped);
    EXPECT_EQ(again.x, snapped.x);
    EXPECT_EQ(again.y, snapped.y);
    if (std::abs(pose.theta) < 3.0) {
      EXPECT_EQ(again.theta, snapped.theta);
    }
    const llc::Pose2 neighbour = llc_ros::canonicalWheelPose(
        {std::nextafter(pose.x, 1e9), std::nextafter(pose.y, -1e9), std::nextafter(pose.theta, 0.0)});
    EXPECT_EQ(neighbour.x, snapped.x);
    EXPECT_EQ(neighbour.y, snapped.y);
    if (std::abs(pose.theta) < 3.0) {
      EXPECT_EQ(neighbour.theta, snapped.theta);
    } else {  // at +-pi the two sides of the wrap are two grid points, 5e-10 rad apart
      EXPECT_NEAR(llc::normalizeAngle(neighbour.theta - snapped.theta), 0.0, 1e-9);
    }
  }
  const llc::Pose2 nan = llc_ros::canonicalWheelPose({std::nan(""), 1.0, 0.0});
  EXPECT_TRUE(std::isnan(nan.x));
}
