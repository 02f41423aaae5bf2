// Conversions between ROS messages and core types: free functions, no state.
#pragma once

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Pose2D.h>
#include <geometry_msgs/Transform.h>
#include <sensor_msgs/LaserScan.h>

#include <string>

#include "laser_loop_closure/Keyframe.h"
#include "laser_loop_closure/PackedKeyframe.h"
#include "laser_loop_closure/core/io/scan_codec.hpp"
#include "laser_loop_closure/LoopClosure.h"
#include "laser_loop_closure/Scan360.h"
#include "laser_loop_closure/core/slam/slam_types.hpp"

namespace llc_ros {

/// A LaserScan as a core scan in the base frame, the scanner mounted at `mount`. Per REP-117,
/// readings above range_max become +inf and readings below range_min -inf (no return / too
/// close); NaN stays NaN. Returns false with a reason for a message that cannot be a scan
/// (non-finite or zero angle increment, angle span disagreeing with the beam count).
bool toScan(const sensor_msgs::LaserScan& msg, const llc::Pose2& mount, llc::Scan* scan,
            std::string* error);

struct ScannerMount {
  llc::Pose2 pose;           ///< scanner frame in the base frame
  bool upside_down = false;  ///< rolled by pi: its beams sweep clockwise seen from above
};

/// toScan for a scanner with this mounting (an upside-down one is mirrored first).
bool toBaseScan(const sensor_msgs::LaserScan& msg, const ScannerMount& mount, llc::Scan* scan, std::string* error);

/// A scan resampled by llc::mergeScans with output_beams > 0 (equal cells over 360 degrees,
/// +inf where nothing returned) as a LaserScan of constant size, in the header's frame.
sensor_msgs::LaserScan toLaserScan(const llc::Scan& resampled, const std_msgs::Header& header, float range_min,
                                   float range_max);

laser_loop_closure::Scan360 toScan360(const llc::Scan& scan, const std_msgs::Header& header);
/// False with a reason when ranges and bearings differ in length.
bool fromScan360(const laser_loop_closure::Scan360& msg, llc::Scan* scan, std::string* error);
/// The scan as a Scan360 message carries it (ranges and bearings rounded to float32): what the
/// loop_closure nodelet computes with. `llc slam --bag` takes its scans through this too, so that
/// the nodelets and the offline tool compute on the same numbers (online = offline).
llc::Scan asTransmitted(const llc::Scan& scan);

geometry_msgs::Pose2D toPose2D(const llc::Pose2& pose);
llc::Pose2 fromPose2D(const geometry_msgs::Pose2D& pose);

/// A keyframe and its odometry step as the front end sends it to the back end, and back
/// (false with a reason for a malformed scan). Non-finite motion or wheel odometry is passed
/// on as it is: the back end keeps the keyframe and says what it replaced (SlamBackEnd::addKeyframe).
laser_loop_closure::Keyframe toKeyframeMsg(const llc::Keyframe& keyframe, std::size_t index, const llc::OdometryStep& step,
                                           const std::string& base_frame);
/// The keyframe packed small for a network: its scan packed (llc::packScan with `scan_packing`),
/// step and covariance in float32, no features (a reader computes them again from the scan).
/// Throws std::invalid_argument for a scan packScan refuses.
laser_loop_closure::PackedKeyframe packKeyframeMsg(const laser_loop_closure::Keyframe& msg, const llc::Scan& scan,
                                                   const llc::ScanPackOptions& scan_packing);
/// A packed keyframe as the Keyframe it came from (the scan unpacked into float32 arrays, no
/// features, no frame name); false with a reason for a scan that does not unpack.
bool unpackKeyframeMsg(const laser_loop_closure::PackedKeyframe& packed, laser_loop_closure::Keyframe* msg, std::string* error);
bool fromKeyframeMsg(const laser_loop_closure::Keyframe& msg, llc::Keyframe* keyframe, llc::Pose2* motion,
                     Eigen::Matrix3d* covariance, std::string* error);
laser_loop_closure::LoopClosure toLoopClosureMsg(const llc::LoopClosure& loop, const std_msgs::Header& header);
/// A loop as the back end met it: accepted = applied, with its chi2 and reason.
laser_loop_closure::LoopClosure toLoopClosureMsg(const llc::LoopRecord& record, const std_msgs::Header& header);
llc::LoopClosure fromLoopClosureMsg(const laser_loop_closure::LoopClosure& msg);

/// The planar pose of a 3D pose or transform (x, y, yaw); z, roll and pitch are dropped.
llc::Pose2 toPose2(const geometry_msgs::Pose& pose);
geometry_msgs::Pose toPoseMsg(const llc::Pose2& pose);
geometry_msgs::Transform toTransformMsg(const llc::Pose2& pose);
/// A scanner mounting from a 3D transform (base frame -> scanner frame). A level mount gives
/// its planar pose; an upside-down one (rolled by pi) also, with *upside_down set, since its
/// beams then sweep clockwise seen from above; any other tilt (more than tilt_tolerance rad)
/// is refused with a reason, because the scan then does not lie in the base plane.
bool toPlanarMount(const geometry_msgs::Transform& transform, llc::Pose2* mount, bool* upside_down,
                   std::string* error, double tilt_tolerance = 0.05);
/// The same scan as seen by an upside-down scanner's mirror: angles negated (sweep reversed).
sensor_msgs::LaserScan mirrored(const sensor_msgs::LaserScan& msg);

}  // namespace llc_ros
