#include "laser_loop_closure/ros/nodes/wheel_odometry_reader.hpp"

#include <ros/console.h>

#include <utility>

#include "laser_loop_closure/ros/io/tf_bridge.hpp"

namespace llc_ros {

WheelOdometryReader::WheelOdometryReader(const tf2_ros::Buffer& buffer, std::string odom_frame, double odometry_time_offset,
                                         std::unique_ptr<llc::OdometryTimeOffsetProbe> probe)
    : buffer_(buffer), odom_frame_(std::move(odom_frame)), odometry_time_offset_(odometry_time_offset), probe_(std::move(probe)) {}

bool WheelOdometryReader::read(const laser_loop_closure::Scan360& msg, llc::Pose2* pose, std::string* error) {
  const ros::Time& stamp = msg.header.stamp;
  bool found = false;
  if (odometry_time_offset_ == 0.0) {
    found = lookupPose2(buffer_, odom_frame_, msg.header.frame_id, stamp, pose, error);
  } else if (lookupPose2(buffer_, odom_frame_, msg.header.frame_id, offsetStamp(stamp, odometry_time_offset_), pose, error)) {
    found = true;
  } else {
    // Before the first odometry (the drive's first scans), or after a gap in tf: the odometry at
    // the scan's own stamp, which its tf filter found (the bag reader holds its first message;
    // on sim.bag, whose odometry starts with the scans, the two agree: online_offline.test).
    found = lookupPose2(buffer_, odom_frame_, msg.header.frame_id, stamp, pose, error);
    at_scan_stamp_ += found;
  }
  // On canonicalWheelPose's grid: what tf answers must not depend on when it is asked.
  if (found) *pose = canonicalWheelPose(*pose);
  return found;
}

bool WheelOdometryReader::estimate(const laser_loop_closure::Scan360& msg, const llc::Scan& scan, llc::Pose2* wheel_odometry) {
  if (!probe_) return false;
  const bool was_decided = probe_->result().decided;
  const llc::OdometryLookup lookup = tfOdometryLookup(buffer_, odom_frame_, msg.header.frame_id, msg.header.stamp);
  const double offset = probe_->observe(msg.header.stamp.toSec(), scan, lookup);
  llc::Pose2 pose;
  if (offset != odometry_time_offset_ && llc::OdometryTimeOffsetProbe::readAt(lookup, offset, &pose)) *wheel_odometry = pose;
  return probe_->result().decided && !was_decided;
}

}  // namespace llc_ros
