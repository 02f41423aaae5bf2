#include "laser_loop_closure/ros/io/tf_bridge.hpp"

#include <cmath>
#include <cstdint>

#include <geometry_msgs/TransformStamped.h>
#include <tf2/exceptions.h>

#include "laser_loop_closure/ros/io/msg_conversion.hpp"

namespace llc_ros {

std::string tfFrame(const std::string& frame_id) {
  const std::size_t first = frame_id.find_first_not_of('/');
  return first == std::string::npos ? std::string() : frame_id.substr(first);
}

bool MountCache::lookup(const std::string& frame_id, ScannerMount* mount, std::string* error, bool* fell_back,
                        bool* waiting, bool count_failure) {
  if (waiting) *waiting = false;
  const std::string frame = tfFrame(frame_id);
  const auto found = cache_.find(frame);
  if (found != cache_.end()) {
    *mount = found->second;
    return true;
  }
  if (frame.empty()) {
    *error = "the scan has no frame_id";
    return false;
  }
  ScannerMount fresh;
  if (frame != base_) {
    geometry_msgs::TransformStamped t;
    try {
      t = buffer_.lookupTransform(base_, frame, ros::Time(0));
    } catch (const tf2::TransformException& e) {
      *error = "no mounting of scanner frame '" + frame + "' on '" + base_ + "' in tf: " + e.what();
      int& failures = failures_[frame];
      if (count_failure) ++failures;
      if (fallback_.after_failures <= 0 || failures < fallback_.after_failures) {
        if (waiting) *waiting = true;
        return false;
      }
      // tf will not tell: the robot's description has no such frame (a bag with no /tf).
      fresh.pose = fallback_.pose;
      ++fallbacks_;
      if (fell_back) *fell_back = true;
      *mount = cache_.emplace(frame, fresh).first->second;
      return true;
    }
    if (!toPlanarMount(t.transform, &fresh.pose, &fresh.upside_down, error)) {
      *error = "scanner frame '" + frame + "': " + *error;
      return false;
    }
  }
  *mount = cache_.emplace(frame, fresh).first->second;
  return true;
}

bool lookupPose2(const tf2_ros::Buffer& buffer, const std::string& parent, const std::string& child,
                 const ros::Time& stamp, llc::Pose2* pose, std::string* error) {
  try {
    const geometry_msgs::TransformStamped t = buffer.lookupTransform(tfFrame(parent), tfFrame(child), stamp);
    geometry_msgs::Pose p;
    p.position.x = t.transform.translation.x;
    p.position.y = t.transform.translation.y;
    p.orientation = t.transform.rotation;
    *pose = toPose2(p);
    return true;
  } catch (const tf2::TransformException& e) {
    *error = e.what();
    return false;
  }
}

llc::Pose2 canonicalWheelPose(const llc::Pose2& pose) {
  // 1e9 x (|value| < 9e6 m) stays an exact integer in a double: the grid is the same everywhere.
  const auto snap = [](double value) { return std::round(value * 1e9) / 1e9; };
  // (The heading may end up to 5e-10 rad beyond pi: every later step normalises it.)
  return {snap(pose.x), snap(pose.y), snap(llc::normalizeAngle(pose.theta))};
}

ros::Time offsetStamp(const ros::Time& stamp, double offset) {
  const ros::Duration shift(offset);
  if (shift.toNSec() < 0 && stamp.toNSec() <= std::uint64_t(-shift.toNSec())) return ros::Time(0, 1);
  return stamp + shift;
}

llc::OdometryLookup tfOdometryLookup(const tf2_ros::Buffer& buffer, const std::string& odom_frame, const std::string& frame,
                                     const ros::Time& stamp) {
  return [&buffer, odom_frame, frame, stamp](double offset, llc::Pose2* pose) {
    std::string error;
    if (!lookupPose2(buffer, odom_frame, frame, offsetStamp(stamp, offset), pose, &error)) return false;
    *pose = canonicalWheelPose(*pose);
    return true;
  };
}

}  // namespace llc_ros
