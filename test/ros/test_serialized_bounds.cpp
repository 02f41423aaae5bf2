// serializedMessageFits against ROS's own serializer: every message it writes fits, to the
// byte; one byte less, one more, or a length that claims more than the bytes hold does not.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <vector>

#include <nav_msgs/Odometry.h>
#include <ros/serialization.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_msgs/TFMessage.h>

#include "laser_loop_closure/ros/io/serialized_bounds.hpp"

namespace {

template <class T>
std::vector<std::uint8_t> bytesOf(const T& msg) {
  std::vector<std::uint8_t> bytes(ros::serialization::serializationLength(msg));
  ros::serialization::OStream out(bytes.data(), bytes.size());
  ros::serialization::serialize(out, msg);
  return bytes;
}

bool fits(const std::string& type, const std::vector<std::uint8_t>& bytes) {
  return llc_ros::serializedMessageFits(type, bytes.data(), bytes.size());
}

void putLength(std::vector<std::uint8_t>& bytes, std::size_t at, std::uint32_t length) {
  std::memcpy(bytes.data() + at, &length, sizeof length);
}

sensor_msgs::LaserScan scan(std::size_t beams, std::size_t intensities) {
  sensor_msgs::LaserScan msg;
  msg.header.frame_id = "laser_front";
  msg.ranges.assign(beams, 2.5f);
  msg.intensities.assign(intensities, 1.0f);
  return msg;
}

/// Every way of ending early or going on past the message is refused.
void expectOnlyTheWholeFits(const std::string& type, const std::vector<std::uint8_t>& bytes) {
  EXPECT_TRUE(fits(type, bytes));
  for (std::size_t n = 0; n < bytes.size(); ++n)
    EXPECT_FALSE(llc_ros::serializedMessageFits(type, bytes.data(), n)) << type << " cut to " << n << " bytes";
  std::vector<std::uint8_t> longer = bytes;
  longer.push_back(0);
  EXPECT_FALSE(fits(type, longer));
}

TEST(SerializedBounds, ALaserScanFitsItsBytesExactly) {
  for (std::size_t beams : {0, 1, 361}) expectOnlyTheWholeFits("sensor_msgs/LaserScan", bytesOf(scan(beams, beams / 2)));
}

TEST(SerializedBounds, ARangesLengthBeyondTheBytesIsRefusedBeforeAnythingIsSized) {
  std::vector<std::uint8_t> bytes = bytesOf(scan(361, 0));
  // seq, stamp, frame_id (length + 11 bytes), seven float32: then the ranges' length.
  const std::size_t at = 12 + 4 + 11 + 7 * 4;
  std::uint32_t written = 0;
  std::memcpy(&written, bytes.data() + at, sizeof written);
  ASSERT_EQ(written, 361u);
  for (std::uint32_t claimed : {362u, 430000000u, 0xffffffffu}) {
    putLength(bytes, at, claimed);
    EXPECT_FALSE(fits("sensor_msgs/LaserScan", bytes)) << claimed;
  }
  putLength(bytes, at, 360);  // one float32 fewer: four bytes left over where intensities' length is read
  EXPECT_FALSE(fits("sensor_msgs/LaserScan", bytes));
  putLength(bytes, 12, 0xfffffff0u);  // the frame_id's length
  EXPECT_FALSE(fits("sensor_msgs/LaserScan", bytes));
}

TEST(SerializedBounds, OdometryAndTransformsFitTheirBytesExactly) {
  nav_msgs::Odometry odom;
  odom.header.frame_id = "odom";
  odom.child_frame_id = "base_link";
  odom.pose.covariance[0] = 0.1;
  expectOnlyTheWholeFits("nav_msgs/Odometry", bytesOf(odom));
  tf2_msgs::TFMessage tf;
  expectOnlyTheWholeFits("tf2_msgs/TFMessage", bytesOf(tf));
  for (const char* child : {"laser_front", "laser_back", ""}) {
    geometry_msgs::TransformStamped t;
    t.header.frame_id = "base_link";
    t.child_frame_id = child;
    t.transform.rotation.w = 1.0;
    tf.transforms.push_back(t);
  }
  std::vector<std::uint8_t> bytes = bytesOf(tf);
  expectOnlyTheWholeFits("tf2_msgs/TFMessage", bytes);
  putLength(bytes, 0, 4000000000u);  // the transforms' count
  EXPECT_FALSE(fits("tf2_msgs/TFMessage", bytes));
  putLength(bytes, 0, 4);  // one more than there are
  EXPECT_FALSE(fits("tf2_msgs/TFMessage", bytes));
}

TEST(SerializedBounds, AnotherTypeIsNotVouchedFor) {
  EXPECT_FALSE(fits("sensor_msgs/PointCloud2", bytesOf(scan(3, 0))));
}

}  // namespace
