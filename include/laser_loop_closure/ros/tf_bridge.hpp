// tf2 lookups the nodelets need: scanner mountings (cached per frame_id, since they do not
// move) and the wheel-odometry pose of the base at a scan's stamp.
#pragma once

#include <ros/time.h>
#include <tf2_ros/buffer.h>

#include <map>
#include <string>

#include "laser_loop_closure/ros/msg_conversion.hpp"

namespace llc_ros {

/// Mountings of scanner frames on the base frame, looked up once per frame_id and kept.
class MountCache {
 public:
  MountCache(const tf2_ros::Buffer& buffer, std::string base_frame) : buffer_(buffer), base_(std::move(base_frame)) {}
  /// False with a reason when tf has no transform yet (try again later) or the mount is
  /// tilted out of the base plane (refused; the reason says so and it is not cached).
  bool lookup(const std::string& frame, ScannerMount* mount, std::string* error);
  const std::string& baseFrame() const { return base_; }

 private:
  const tf2_ros::Buffer& buffer_;
  std::string base_;
  std::map<std::string, ScannerMount> cache_;
};

/// The planar pose of `child` in `parent` at `stamp`, from what the buffer holds now: it never
/// waits (a wait on the ROS clock never ends once a bag stops). False with tf's reason when it
/// is not there; a caller that must wait for tf uses a tf2_ros::MessageFilter first.
bool lookupPose2(const tf2_ros::Buffer& buffer, const std::string& parent, const std::string& child,
                 const ros::Time& stamp, llc::Pose2* pose, std::string* error);

}  // namespace llc_ros
