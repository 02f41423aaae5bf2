// A scan at rest: what a keyframe keeps between the times it is aligned or drawn. It holds the
// same values as the Scan it was made from, in fewer bytes: each array in single precision when
// every value is one exactly (a ROS message's are: half the bytes), and the bearings shared with
// another compact scan that has the same ones (a merged scan's resampled beams, or one scanner's
// fixed beams, are the same in every scan: a 720-beam scan then keeps 2.9 kB, not 11.5).
#pragma once

#include <cstddef>
#include <memory>
#include <vector>

#include "laser_loop_closure/core/geometry/scan.hpp"

namespace llc {

/// An array of doubles kept as floats when every value is one exactly (NaN and infinities
/// included), else as doubles: read back bit for bit the same.
class CompactValues {
 public:
  CompactValues() = default;
  explicit CompactValues(const std::vector<double>& values);
  std::size_t size() const { return single_.size() + wide_.size(); }
  /// The values, as they were given.
  std::vector<double> values() const;
  /// The same values as `values` (NaN equals NaN).
  bool equals(const std::vector<double>& values) const;
  /// Bytes of the values held.
  std::size_t bytes() const { return single_.size() * sizeof(float) + wide_.size() * sizeof(double); }

 private:
  std::vector<float> single_;  ///< the values, when each is a float exactly
  std::vector<double> wide_;   ///< else the values
};

class CompactScan {
 public:
  /// `scan` kept compact; its bearings shared with `same_beams` when that one's are the same
  /// (null: nothing to share with).
  explicit CompactScan(const Scan& scan, const CompactScan* same_beams = nullptr);
  /// The scan it was made from, value for value.
  Scan scan() const;
  std::size_t size() const { return ranges_.size(); }
  double stamp() const { return stamp_; }
  /// Bytes held: the ranges, and the bearings when this scan did not take them from another
  /// (so the bytes of several scans add up to what they hold together).
  std::size_t bytes() const;

 private:
  CompactValues ranges_;
  std::shared_ptr<const CompactValues> bearings_;
  double stamp_ = 0.0;
  bool full_circle_ = false;
  bool shares_bearings_ = false;  ///< bearings_ came from another scan
};

}  // namespace llc
