// Bounds a serialized message before ROS deserializes it. roscpp's deserializer sizes a vector
// from the length written before it, then checks that the bytes exist: one corrupted length in
// a bag claims gigabytes (a scan's ranges at 4e8 took 1.7 GB before "Buffer Overrun"). The
// readers here walk the bytes as the type lays them out and refuse a length the bytes left
// cannot hold, so a damaged bag costs no more memory than its own size.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace llc_ros {

/// Reads a serialized ROS message's layout without allocating: each step advances past a field
/// if the bytes left hold it, else the walk fails and stays failed.
class SerializedWalk {
 public:
  SerializedWalk(const std::uint8_t* data, std::size_t size) : data_(data), left_(size) {}
  /// Fixed-size fields of `bytes` in all.
  bool skip(std::size_t bytes);
  /// A uint32 length, then that many bytes (a string).
  bool string() { return array(1); }
  /// A uint32 count, then that many elements of `element_bytes` each (a fixed-size type's array).
  bool array(std::size_t element_bytes);
  /// A uint32 count of elements of at least `min_element_bytes` each; the count read or 0 (then ok() says).
  std::uint32_t count(std::size_t min_element_bytes);
  /// std_msgs/Header: seq, stamp, frame_id.
  bool header() { return skip(12) && string(); }
  bool ok() const { return ok_; }
  /// The whole message was walked, no byte left over.
  bool done() const { return ok_ && left_ == 0; }

 private:
  std::uint32_t readLength();
  const std::uint8_t* data_;
  std::size_t left_;
  bool ok_ = true;
};

/// Whether `size` bytes hold one serialized message of `datatype` with every length in bounds
/// ("sensor_msgs/LaserScan", "nav_msgs/Odometry", "tf2_msgs/TFMessage"); another type: false.
bool serializedMessageFits(const std::string& datatype, const std::uint8_t* data, std::size_t size);

}  // namespace llc_ros
