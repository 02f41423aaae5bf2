#include "laser_loop_closure/ros/io/msg_conversion.hpp"

#include "laser_loop_closure/core/io/scan_codec.hpp"

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

llc::Scan asTransmitted(const llc::Scan& scan) {
  llc::Scan out = scan;
  for (double& r : out.ranges) r = double(float(r));
  for (double& b : out.bearings) b = double(float(b));
  return out;
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

bool toBaseScan(const sensor_msgs::LaserScan& msg, const ScannerMount& mount, llc::Scan* scan, std::string* error) {
  return toScan(mount.upside_down ? mirrored(msg) : msg, mount.pose, scan, error);
}

sensor_msgs::LaserScan toLaserScan(const llc::Scan& resampled, const std_msgs::Header& header, float range_min,
                                   float range_max) {
  sensor_msgs::LaserScan msg;
  msg.header = header;
  const std::size_t n = resampled.size();
  if (n == 0) return msg;
  const double step = 2.0 * M_PI / double(n);
  msg.angle_min = float(resampled.bearings.front());
  msg.angle_increment = float(step);
  msg.angle_max = float(resampled.bearings.front() + double(n - 1) * step);
  msg.range_min = range_min;
  msg.range_max = range_max;
  msg.ranges.resize(n);
  const float inf = std::numeric_limits<float>::infinity();
  for (std::size_t i = 0; i < n; ++i) {
    const double r = resampled.ranges[i];
    msg.ranges[i] = std::isfinite(r) && r >= 0.0 ? float(r) : inf;
  }
  return msg;
}

geometry_msgs::Pose2D toPose2D(const llc::Pose2& pose) {
  geometry_msgs::Pose2D msg;
  msg.x = pose.x, msg.y = pose.y, msg.theta = pose.theta;
  return msg;
}

llc::Pose2 fromPose2D(const geometry_msgs::Pose2D& pose) { return {pose.x, pose.y, pose.theta}; }

namespace {
template <class Array>
void toArray(const Eigen::Matrix3d& m, Array* out) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) (*out)[std::size_t(3 * r + c)] = m(r, c);
}
template <class Array>
Eigen::Matrix3d fromArray(const Array& a) {
  Eigen::Matrix3d m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m(r, c) = a[std::size_t(3 * r + c)];
  return m;
}
}  // namespace

laser_loop_closure::Keyframe toKeyframeMsg(const llc::Keyframe& keyframe, std::size_t index, const llc::OdometryStep& step,
                                           const std::string& base_frame) {
  laser_loop_closure::Keyframe msg;
  msg.header.stamp.fromSec(keyframe.stamp);
  msg.header.frame_id = base_frame;
  msg.index = std::uint32_t(index);
  msg.scan_index = std::uint32_t(keyframe.scan_index);
  msg.scan = toScan360(keyframe.scan, msg.header);
  msg.has_wheel_odometry = keyframe.has_wheel_odometry;
  msg.wheel_odometry = toPose2D(keyframe.wheel_odometry);
  msg.motion = toPose2D(step.motion);
  toArray(step.covariance, &msg.motion_covariance);
  msg.scan_matched = step.matched;
  return msg;
}

laser_loop_closure::PackedKeyframe packKeyframeMsg(const laser_loop_closure::Keyframe& msg, const llc::Scan& scan,
                                                   const llc::ScanPackOptions& scan_packing) {
  laser_loop_closure::PackedKeyframe packed;
  packed.scan = llc::packScan(scan, scan_packing);
  packed.stamp = msg.header.stamp;
  packed.index = msg.index;
  packed.scan_index = msg.scan_index;
  packed.loops_before = msg.loops_before;
  packed.has_wheel_odometry = msg.has_wheel_odometry;
  packed.scan_matched = msg.scan_matched;
  packed.wheel_odometry = {msg.wheel_odometry.x, msg.wheel_odometry.y, msg.wheel_odometry.theta};
  packed.motion = {float(msg.motion.x), float(msg.motion.y), float(msg.motion.theta)};
  const auto& c = msg.motion_covariance;  // row-major 3x3, symmetric
  packed.motion_covariance = {float(c[0]), float(c[1]), float(c[2]), float(c[4]), float(c[5]), float(c[8])};
  return packed;
}

bool unpackKeyframeMsg(const laser_loop_closure::PackedKeyframe& packed, laser_loop_closure::Keyframe* msg, std::string* error) {
  llc::Scan scan;
  if (!llc::unpackScan(packed.scan, &scan, error)) return false;
  laser_loop_closure::Keyframe out;
  out.header.stamp = packed.stamp;
  out.index = packed.index;
  out.scan_index = packed.scan_index;
  out.loops_before = packed.loops_before;
  out.scan = toScan360(scan, out.header);
  out.has_wheel_odometry = packed.has_wheel_odometry;
  out.scan_matched = packed.scan_matched;
  out.wheel_odometry.x = packed.wheel_odometry[0], out.wheel_odometry.y = packed.wheel_odometry[1];
  out.wheel_odometry.theta = packed.wheel_odometry[2];
  out.motion.x = packed.motion[0], out.motion.y = packed.motion[1], out.motion.theta = packed.motion[2];
  const auto& u = packed.motion_covariance;  // xx, xy, xtheta, yy, ytheta, thetatheta
  out.motion_covariance = {u[0], u[1], u[2], u[1], u[3], u[4], u[2], u[4], u[5]};
  *msg = std::move(out);
  return true;
}

bool fromKeyframeMsg(const laser_loop_closure::Keyframe& msg, llc::Keyframe* keyframe, llc::Pose2* motion,
                     Eigen::Matrix3d* covariance, std::string* error) {
  if (!fromScan360(msg.scan, &keyframe->scan, error)) return false;
  keyframe->scan_index = msg.scan_index;
  keyframe->stamp = msg.header.stamp.toSec();
  keyframe->scan.stamp = keyframe->stamp;
  keyframe->has_wheel_odometry = msg.has_wheel_odometry;
  keyframe->wheel_odometry = fromPose2D(msg.wheel_odometry);
  *motion = fromPose2D(msg.motion);
  *covariance = fromArray(msg.motion_covariance);
  return true;
}

laser_loop_closure::LoopClosure toLoopClosureMsg(const llc::LoopClosure& loop, const std_msgs::Header& header) {
  laser_loop_closure::LoopClosure msg;
  msg.header = header;
  msg.from_keyframe = std::uint32_t(loop.from);
  msg.to_keyframe = std::uint32_t(loop.to);
  msg.score = loop.score;
  msg.pose = toPose2D(loop.pose);
  toArray(loop.covariance, &msg.covariance);
  msg.inlier_share = loop.inlier_share;
  msg.accepted = loop.accepted;
  msg.refusal = std::uint8_t(loop.refusal);
  msg.reject_reason = loop.reject_reason;
  return msg;
}

laser_loop_closure::LoopClosure toLoopClosureMsg(const llc::LoopRecord& record, const std_msgs::Header& header) {
  laser_loop_closure::LoopClosure msg = toLoopClosureMsg(record.loop, header);
  msg.accepted = record.applied;
  msg.refusal = std::uint8_t(record.refusal);
  msg.reject_reason = record.reject_reason;
  msg.innovation_chi2 = record.innovation_chi2;
  return msg;
}

llc::LoopClosure fromLoopClosureMsg(const laser_loop_closure::LoopClosure& msg) {
  llc::LoopClosure loop;
  loop.from = msg.from_keyframe;
  loop.to = msg.to_keyframe;
  loop.score = msg.score;
  loop.pose = fromPose2D(msg.pose);
  loop.covariance = fromArray(msg.covariance);
  loop.inlier_share = msg.inlier_share;
  loop.accepted = msg.accepted;
  // A code this build does not know (a newer sender) counts as kOther, not as a crash or a guess.
  loop.refusal = msg.refusal < llc::kLoopRefusalKinds ? llc::LoopRefusal(msg.refusal) : llc::LoopRefusal::kOther;
  loop.reject_reason = msg.reject_reason;
  return loop;
}

}  // namespace llc_ros
