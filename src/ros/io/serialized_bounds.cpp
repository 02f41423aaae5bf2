#include "laser_loop_closure/ros/io/serialized_bounds.hpp"

#include <cstring>

namespace llc_ros {

bool SerializedWalk::skip(std::size_t bytes) {
  if (!ok_ || bytes > left_) return ok_ = false;
  data_ += bytes;
  left_ -= bytes;
  return true;
}

std::uint32_t SerializedWalk::readLength() {
  std::uint32_t length = 0;
  if (!ok_ || left_ < sizeof length) {
    ok_ = false;
    return 0;
  }
  std::memcpy(&length, data_, sizeof length);  // little-endian, as ROS serializes
  skip(sizeof length);
  return length;
}

bool SerializedWalk::array(std::size_t element_bytes) {
  const std::uint32_t n = readLength();
  if (!ok_ || (element_bytes > 0 && n > left_ / element_bytes)) return ok_ = false;
  return skip(std::size_t(n) * element_bytes);
}

std::uint32_t SerializedWalk::count(std::size_t min_element_bytes) {
  const std::uint32_t n = readLength();
  if (!ok_ || (min_element_bytes > 0 && n > left_ / min_element_bytes)) {
    ok_ = false;
    return 0;
  }
  return n;
}

namespace {

constexpr std::size_t kFloat32 = 4, kFloat64 = 8;
constexpr std::size_t kHeaderMin = 12 + 4;  // seq, stamp, an empty frame_id

bool laserScanFits(SerializedWalk& w) {
  // angle_min, angle_max, angle_increment, time_increment, scan_time, range_min, range_max; ranges; intensities
  return w.header() && w.skip(7 * kFloat32) && w.array(kFloat32) && w.array(kFloat32);
}

bool odometryFits(SerializedWalk& w) {
  // child_frame_id; pose (position, orientation, covariance[36]); twist (linear, angular, covariance[36])
  return w.header() && w.string() && w.skip((7 + 36) * kFloat64) && w.skip((6 + 36) * kFloat64);
}

bool tfMessageFits(SerializedWalk& w) {
  // geometry_msgs/TransformStamped[]: header, child_frame_id, translation, rotation
  const std::size_t min_transform = kHeaderMin + 4 + 7 * kFloat64;
  const std::uint32_t n = w.count(min_transform);
  for (std::uint32_t i = 0; i < n && w.ok(); ++i) w.header() && w.string() && w.skip(7 * kFloat64);
  return w.ok();
}

}  // namespace

bool serializedMessageFits(const std::string& datatype, const std::uint8_t* data, std::size_t size) {
  SerializedWalk walk(data, size);
  if (datatype == "sensor_msgs/LaserScan") laserScanFits(walk);
  else if (datatype == "nav_msgs/Odometry") odometryFits(walk);
  else if (datatype == "tf2_msgs/TFMessage") tfMessageFits(walk);
  else return false;
  return walk.done();
}

}  // namespace llc_ros
