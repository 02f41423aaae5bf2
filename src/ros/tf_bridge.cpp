#include "laser_loop_closure/ros/tf_bridge.hpp"

#include <geometry_msgs/TransformStamped.h>
#include <tf2/exceptions.h>

#include "laser_loop_closure/ros/msg_conversion.hpp"

namespace llc_ros {

bool MountCache::lookup(const std::string& frame, ScannerMount* mount, std::string* error) {
  const auto found = cache_.find(frame);
  if (found != cache_.end()) {
    *mount = found->second;
    return true;
  }
  ScannerMount fresh;
  if (frame != base_) {
    geometry_msgs::TransformStamped t;
    try {
      t = buffer_.lookupTransform(base_, frame, ros::Time(0));
    } catch (const tf2::TransformException& e) {
      *error = "no mounting of scanner frame '" + frame + "' on '" + base_ + "' in tf: " + e.what();
      return false;
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
    const geometry_msgs::TransformStamped t = buffer.lookupTransform(parent, child, stamp);
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

}  // namespace llc_ros
