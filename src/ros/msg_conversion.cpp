#include "laser_loop_closure/ros/msg_conversion.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <tf2/LinearMath/Matrix3x3.h>
#include <tf2/LinearMath/Quaternion.h>

namespace llc_ros {

bool toScan(const sensor_msgs::LaserScan& msg, const llc::Pose2& mount, llc::Scan* scan,
            std::string* error) {
  if (!std::isfinite(msg.angle_increment) || msg.angle_increment == 0.0f) {
    *error = "angle_increment is zero or not finite";
    return false;
  }
  if (!std::isfinite(msg.angle_min) || !std::isfinite(msg.angle_max)) {
    *error = "angle_min or angle_max is not finite";
    return false;
  }
  const double expected = (double(msg.angle_max) - msg.angle_min) / msg.angle_increment + 1.0;
  if (!msg.ranges.empty() && std::abs(expected - double(msg.ranges.size())) > 1.5) {
    *error = "the angles span " + std::to_string(expected) + " beams but the scan has " +
             std::to_string(msg.ranges.size());
    return false;
  }
  llc::ScannerGeometry geometry;
  geometry.angle_min = msg.angle_min;
  geometry.angle_increment = msg.angle_increment;
  geometry.range_max = msg.range_max;
  std::vector<double> ranges(msg.ranges.size());
  const double inf = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < ranges.size(); ++i) {
    const double r = msg.ranges[i];
    if (std::isnan(r)) ranges[i] = r;
    else if (msg.range_max > 0.0f && r > msg.range_max) ranges[i] = inf;
    else if (r < msg.range_min) ranges[i] = -inf;
    else ranges[i] = r;
  }
  *scan = llc::scanFromRanges(ranges, geometry, mount, msg.header.stamp.toSec());
  if (scan->size() > 1 && scan->bearings.front() > scan->bearings.back()) {  // clockwise sweep
    std::reverse(scan->ranges.begin(), scan->ranges.end());
    std::reverse(scan->bearings.begin(), scan->bearings.end());
  }
  return true;
}

laser_loop_closure::Scan360 toScan360(const llc::Scan& scan, const std_msgs::Header& header) {
  laser_loop_closure::Scan360 msg;
  msg.header = header;
  msg.ranges.assign(scan.ranges.begin(), scan.ranges.end());
  msg.bearings.assign(scan.bearings.begin(), scan.bearings.end());
  msg.full_circle = scan.full_circle;
  return msg;
}

bool fromScan360(const laser_loop_closure::Scan360& msg, llc::Scan* scan, std::string* error) {
  if (msg.ranges.size() != msg.bearings.size()) {
    *error = "ranges and bearings differ in length";
    return false;
  }
  scan->ranges.assign(msg.ranges.begin(), msg.ranges.end());
  scan->bearings.assign(msg.bearings.begin(), msg.bearings.end());
  scan->full_circle = msg.full_circle;
  scan->stamp = msg.header.stamp.toSec();
  return true;
}

llc::Pose2 toPose2(const geometry_msgs::Pose& pose) {
  const tf2::Quaternion q(pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w);
  double roll, pitch, yaw;
  tf2::Matrix3x3(q).getRPY(roll, pitch, yaw);
  return {pose.position.x, pose.position.y, yaw};
}

namespace {
geometry_msgs::Quaternion yawQuaternion(double yaw) {
  geometry_msgs::Quaternion q;
  q.z = std::sin(0.5 * yaw);
  q.w = std::cos(0.5 * yaw);
  return q;
}
}  // namespace

geometry_msgs::Pose toPoseMsg(const llc::Pose2& pose) {
  geometry_msgs::Pose msg;
  msg.position.x = pose.x;
  msg.position.y = pose.y;
  msg.orientation = yawQuaternion(pose.theta);
  return msg;
}

geometry_msgs::Transform toTransformMsg(const llc::Pose2& pose) {
  geometry_msgs::Transform msg;
  msg.translation.x = pose.x;
  msg.translation.y = pose.y;
  msg.rotation = yawQuaternion(pose.theta);
  return msg;
}

bool toPlanarMount(const geometry_msgs::Transform& transform, llc::Pose2* mount, bool* upside_down,
                   std::string* error, double tilt_tolerance) {
  const auto& r = transform.rotation;
  const double norm = std::sqrt(r.x * r.x + r.y * r.y + r.z * r.z + r.w * r.w);
  if (!std::isfinite(norm) || norm < 1e-6 || !std::isfinite(transform.translation.x) ||
      !std::isfinite(transform.translation.y)) {
    *error = "the mounting transform is not a valid pose";
    return false;
  }
  const tf2::Quaternion q(r.x / norm, r.y / norm, r.z / norm, r.w / norm);
  // The scanner's z axis in the base frame: up for a level mount, down for an upside-down one.
  const tf2::Matrix3x3 rotation(q);
  const double z_up = rotation[2][2];
  if (z_up > std::cos(tilt_tolerance)) {
    *upside_down = false;
  } else if (z_up < -std::cos(tilt_tolerance)) {
    *upside_down = true;
  } else {
    *error = "the scanner is tilted by " + std::to_string(std::acos(std::max(-1.0, std::min(1.0, z_up)))) +
             " rad from level; only level or upside-down mounts give a scan in the base plane";
    return false;
  }
  // Heading of the scanner's x axis projected on the base plane.
  *mount = {transform.translation.x, transform.translation.y, std::atan2(rotation[1][0], rotation[0][0])};
  return true;
}

sensor_msgs::LaserScan mirrored(const sensor_msgs::LaserScan& msg) {
  sensor_msgs::LaserScan out = msg;
  out.angle_min = -msg.angle_min;
  out.angle_max = -msg.angle_max;
  out.angle_increment = -msg.angle_increment;
  return out;
}

}  // namespace llc_ros
