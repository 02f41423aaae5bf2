// Scanner mountings from tf: frame ids spelt the tf1 way ("/laser") and a bag or robot whose tf
// never tells a scanner's mounting.
#include <gtest/gtest.h>

#include <geometry_msgs/TransformStamped.h>
#include <tf2_ros/buffer.h>

#include <cmath>

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
