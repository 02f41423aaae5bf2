// tf2 lookups the nodelets need: scanner mountings (cached per frame_id, since they do not
// move) and the wheel-odometry pose of the base at a scan's stamp.
#pragma once

#include <ros/time.h>
#include <tf2/buffer_core.h>
#include <tf2_ros/buffer.h>

#include <map>
#include <string>

#include "laser_loop_closure/core/slam/odometry_time_offset_probe.hpp"
#include "laser_loop_closure/ros/io/msg_conversion.hpp"

namespace llc_ros {

/// A frame id as tf2 names it: without the leading slashes of tf1 ("/laser" is "laser").
std::string tfFrame(const std::string& frame_id);

/// The mount a scanner frame gets when tf never tells one: after `after_failures` lookups of
/// that frame found no transform (0: never).
struct FallbackMount {
  llc::Pose2 pose;  ///< in the base frame (m, rad)
  int after_failures = 0;
};

/// Mountings of scanner frames on the base frame, looked up once per frame_id and kept. Frame
/// ids are compared as tfFrame gives them. The buffer is a live node's tf2_ros::Buffer or a
/// bag reader's tf2::BufferCore filled from /tf_static: one cache for both.
class MountCache {
 public:
  MountCache(const tf2::BufferCore& buffer, const std::string& base_frame, FallbackMount fallback = {})
      : buffer_(buffer), base_(tfFrame(base_frame)), fallback_(fallback) {}
  /// False with a reason when tf has no transform yet (try again later) or the mount is
  /// tilted out of the base plane (refused; the reason says so and it is not cached). After
  /// fallback.after_failures lookups without a transform the fallback mount is kept for the
  /// frame and *fell_back (when given) is set, once, so the caller can say so.
  /// *waiting (when given) is set when tf simply has no mount for the frame yet. count_failure
  /// false: a retry of a scan already counted (the fallback comes after that many scans).
  bool lookup(const std::string& frame, ScannerMount* mount, std::string* error, bool* fell_back = nullptr,
              bool* waiting = nullptr, bool count_failure = true);
  const std::string& baseFrame() const { return base_; }
  /// Scanner frames on the fallback mount.
  std::size_t fallbacks() const { return fallbacks_; }

 private:
  const tf2::BufferCore& buffer_;
  std::string base_;
  FallbackMount fallback_;
  std::map<std::string, ScannerMount> cache_;
  std::map<std::string, int> failures_;
  std::size_t fallbacks_ = 0;
};

/// The planar pose of `child` in `parent` at `stamp`, from what the buffer holds now: it never
/// waits (a wait on the ROS clock never ends once a bag stops). False with tf's reason when it
/// is not there; a caller that must wait for tf uses a tf2_ros::MessageFilter first.
bool lookupPose2(const tf2_ros::Buffer& buffer, const std::string& parent, const std::string& child,
                 const ros::Time& stamp, llc::Pose2* pose, std::string* error);

/// Wheel odometry as the pipeline takes it, from tf (the nodelets) or from a bag's odometry
/// (`llc slam --bag`): x and y on a grid of 1e-9 m, the heading on one of 1e-9 rad. tf gives
/// the pose at a stamp that has a transform of its own as it is only while nothing newer has
/// come; once something has, it slerps to it at ratio 0 and may land one unit in the last place
/// away. Which of the two a scan gets depends on when it is looked up (the play rate, the load),
/// and the front end carries a last bit on into other loops (MIT CSAIL's bag with wheels: 20
/// loops at 8x, 25 at 2x). On the grid both are one pose, as is a bag's own interpolation.
llc::Pose2 canonicalWheelPose(const llc::Pose2& pose);

/// The wheel odometry (odom_frame -> frame) in `buffer` at `stamp` plus an offset (s, added in
/// whole nanoseconds as the bag reader adds it), on canonicalWheelPose's grid; false where tf
/// holds none (as lookupPose2, it never waits). `buffer` must outlive it.
llc::OdometryLookup tfOdometryLookup(const tf2_ros::Buffer& buffer, const std::string& odom_frame, const std::string& frame,
                                     const ros::Time& stamp);
/// `stamp` + `offset` s in whole nanoseconds (ros::Duration rounds the offset), never before
/// time 0 + 1 ns (tf reads time 0 as "the latest").
ros::Time offsetStamp(const ros::Time& stamp, double offset);

}  // namespace llc_ros
