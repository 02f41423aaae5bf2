// The adapter's conversions, with no master.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "laser_loop_closure/ros/msg_conversion.hpp"

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

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
