// The loop_closure nodelet's wheel odometry (WheelOdometryReader, tf filled by hand: no master)
// against `llc slam --bag`'s reader of the same bag: the same pose for every scan, to the bit,
// before and after the odometry time offset estimate chooses, and the same choice at the same scan.
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_msgs/TFMessage.h>

#include "../core/test_util.hpp"
#include "laser_loop_closure/core/sim/sim_world.hpp"
#include "laser_loop_closure/ros/io/bag_io.hpp"
#include "laser_loop_closure/ros/io/msg_conversion.hpp"
#include "laser_loop_closure/ros/nodes/wheel_odometry_reader.hpp"

namespace {

llc::OdometryTimeOffsetProbeOptions fewPairs() {
  llc::OdometryTimeOffsetProbeOptions options;
  options.pairs = 20;  // the simulated drive turns seldom
  return options;
}

std::unique_ptr<llc::OdometryTimeOffsetProbe> probe() {
  return std::make_unique<llc::OdometryTimeOffsetProbe>(llc::ScanOdometry{}, llc::ScanAligner{}, 0.0, fewPairs());
}

struct EarlyOdometryBag {
  llc_test::TempDir dir;
  std::string path = dir.file("early.bag");
  double period = 0.0;
  EarlyOdometryBag() {
    llc::SimDriveOptions options;
    options.length_m = 600.0;
    const llc::SimWorld world(llc::simWorldOptions(options));
    llc::SimDrive drive = llc::simulateDrive(world, options);
    period = drive.frames[1].stamp - drive.frames[0].stamp;
    // Each odometry message stamped a period before the pose it holds (scans stamped late).
    for (std::size_t k = 0; k + 1 < drive.frames.size(); ++k) drive.frames[k].odometry = drive.frames[k + 1].odometry;
    llc_ros::writeSimBag(drive, path);
  }
};

}  // namespace

TEST(WheelOdometryReader, ReadsWhatTheBagReaderReadsAndChoosesTheSameOffsetAtTheSameScan) {
  const EarlyOdometryBag bag;
  llc::OdometryTimeOffsetProbe offline_probe(llc::ScanOdometry{}, llc::ScanAligner{}, 0.0, fewPairs());
  llc_ros::BagReadOptions read;
  read.odometry_time_offset_probe = &offline_probe;
  const llc::ScanSequence offline = llc_ros::readBagSequence(bag.path, read);
  ASSERT_TRUE(offline_probe.result().decided);

  // The bag played into tf as the nodelet's buffer takes it (default cache), each scan read
  // once its own stamp's transform is in, as the tf filter lets it by.
  std::vector<geometry_msgs::TransformStamped> transforms;
  std::vector<ros::Time> scan_stamps;
  rosbag::Bag file(bag.path);
  for (const rosbag::MessageInstance& m : rosbag::View(file)) {
    if (m.getTopic() == "/tf") {
      const tf2_msgs::TFMessage::ConstPtr tf = m.instantiate<tf2_msgs::TFMessage>();  // alive through the loop
      for (const auto& t : tf->transforms) transforms.push_back(t);
    }
    if (m.getTopic() == "/scan_front") scan_stamps.push_back(m.instantiate<sensor_msgs::LaserScan>()->header.stamp);
  }
  ASSERT_EQ(scan_stamps.size(), offline.scans.size());
  tf2_ros::Buffer buffer;
  llc_ros::WheelOdometryReader reader(buffer, "odom", 0.0, probe());
  std::size_t next_transform = 0, chose_at = 0, chose = 0;
  for (std::size_t k = 0; k < scan_stamps.size(); ++k) {
    while (next_transform < transforms.size() && transforms[next_transform].header.stamp <= scan_stamps[k])
      buffer.setTransform(transforms[next_transform++], "bag");
    std_msgs::Header header;
    header.stamp = scan_stamps[k];
    header.frame_id = "base_link";
    const laser_loop_closure::Scan360 msg = llc_ros::toScan360(offline.scans[k].scan, header);
    llc::Scan scan;
    std::string error;
    ASSERT_TRUE(llc_ros::fromScan360(msg, &scan, &error)) << error;
    llc::Pose2 pose;
    ASSERT_TRUE(reader.read(msg, &pose, &error)) << k << ": " << error;
    if (reader.estimate(msg, scan, &pose)) chose_at = k, ++chose;
    EXPECT_EQ(pose.x, offline.scans[k].odometry.x) << k;
    EXPECT_EQ(pose.y, offline.scans[k].odometry.y) << k;
    EXPECT_EQ(pose.theta, offline.scans[k].odometry.theta) << k;
  }
  ASSERT_EQ(chose, 1u) << "the choice is made once";
  const llc::OdometryTimeOffsetProbeResult& online = *reader.estimateResult();
  EXPECT_EQ(chose_at, offline_probe.result().decided_at_scan);
  EXPECT_EQ(online.decided_at_scan, offline_probe.result().decided_at_scan);
  EXPECT_EQ(online.offset, offline_probe.result().offset);
  EXPECT_NEAR(online.offset, -bag.period, 1e-6) << online.estimate.reason;
  EXPECT_EQ(reader.atScanStamp(), 0u) << "offset 0 until the choice: never before the first reading";
}

TEST(WheelOdometryReader, FallsBackToTheScansOwnStampAndSaysWhyWhenTfHasNothing) {
  tf2_ros::Buffer buffer;
  geometry_msgs::TransformStamped t;
  t.header.frame_id = "odom";
  t.child_frame_id = "base_link";
  t.transform.rotation.w = 1.0;
  t.header.stamp = ros::Time(100, 0);
  t.transform.translation.x = 1.0;
  buffer.setTransform(t, "test");
  t.header.stamp = ros::Time(101, 0);
  t.transform.translation.x = 2.0;
  buffer.setTransform(t, "test");
  llc_ros::WheelOdometryReader reader(buffer, "odom", -0.5, nullptr);
  laser_loop_closure::Scan360 msg;
  msg.header.frame_id = "base_link";
  llc::Pose2 pose;
  std::string error;
  msg.header.stamp = ros::Time(100, 800000000);
  ASSERT_TRUE(reader.read(msg, &pose, &error)) << error;
  EXPECT_NEAR(pose.x, 1.3, 1e-9) << "0.5 s before the scan";
  msg.header.stamp = ros::Time(100, 200000000);
  ASSERT_TRUE(reader.read(msg, &pose, &error)) << error;
  EXPECT_NEAR(pose.x, 1.2, 1e-9) << "before the first reading: at the scan's own stamp";
  EXPECT_EQ(reader.atScanStamp(), 1u);
  msg.header.stamp = ros::Time(99, 0);
  EXPECT_FALSE(reader.read(msg, &pose, &error));
  EXPECT_FALSE(error.empty());
  EXPECT_EQ(reader.estimateResult(), nullptr) << "no probe, no estimate";
  llc::Scan scan;
  EXPECT_FALSE(reader.estimate(msg, scan, &pose));
}
