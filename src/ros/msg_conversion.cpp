#include "laser_loop_closure/ros/msg_conversion.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

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

}  // namespace llc_ros
