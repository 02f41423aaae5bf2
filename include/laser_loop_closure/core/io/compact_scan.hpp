// A scan at rest: what a keyframe keeps between the times it is aligned or drawn. It holds the
// same values as the Scan it was made from, in fewer bytes: each array as floats coded without
// loss when every value is one exactly (a ROS message's are: about a quarter of the doubles'
// bytes), and the bearings shared with another compact scan that has the same ones (a merged
// scan's resampled beams, or one scanner's fixed beams, are the same in every scan).
// Where a scan serves only to be drawn and saved (a back end's map), it may be kept packed
// instead (packScan: about 1.2 kB for 722 beams at 0.5 mm and 1e-5 rad steps, each point within
// half a step of where it was).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "laser_loop_closure/core/geometry/scan.hpp"
#include "laser_loop_closure/core/io/scan_codec.hpp"

namespace llc {

/// An array of doubles kept, when every value is a float exactly (NaN and infinities included),
/// as those floats coded without loss: each float's bits as an integer in the floats' order,
/// less what the last finite ones predict (SequencePredictor), through the range coder; about
/// half of float32's bytes for a scan's ranges and bearings. Else kept as doubles. Read back
/// bit for bit the same.
class CompactValues {
 public:
  CompactValues() = default;
  explicit CompactValues(const std::vector<double>& values);
  std::size_t size() const { return count_; }
  /// The values, as they were given.
  std::vector<double> values() const;
  /// The same values as `values` (NaN equals NaN).
  bool equals(const std::vector<double>& values) const;
  /// Bytes of the values held.
  std::size_t bytes() const { return coded_.capacity() + wide_.capacity() * sizeof(double); }

 private:
  std::size_t count_ = 0;
  std::vector<std::uint8_t> coded_;  ///< the floats coded, when each value is a float exactly
  std::vector<double> wide_;         ///< else the values
};

class CompactScan {
 public:
  /// `scan` kept compact; its bearings shared with `same_beams` when that one's are the same
  /// (null: nothing to share with).
  explicit CompactScan(const Scan& scan, const CompactScan* same_beams = nullptr);
  /// `scan` kept packed with `packing` (the stamp and full_circle exact); kept as the
  /// constructor keeps it when it cannot be packed (a bearing not finite, arrays of different
  /// lengths): no scan is lost.
  static CompactScan packed(const Scan& scan, const ScanPackOptions& packing);
  /// The scan it was made from: value for value, or as unpackScan gives it back when packed.
  Scan scan() const;
  bool isPacked() const { return !packed_.empty(); }
  std::size_t size() const { return beams_; }
  double stamp() const { return stamp_; }
  /// Bytes held: the ranges, and the bearings when this scan did not take them from another
  /// (so the bytes of several scans add up to what they hold together).
  std::size_t bytes() const;

 private:
  CompactScan() = default;
  std::size_t beams_ = 0;
  CompactValues ranges_;
  std::shared_ptr<const CompactValues> bearings_;
  double stamp_ = 0.0;
  bool full_circle_ = false;
  bool shares_bearings_ = false;  ///< bearings_ came from another scan
  std::vector<std::uint8_t> packed_;  ///< packScan's bytes (then ranges_ and bearings_ are empty)
};

/// How a back end keeps its keyframes' scans for the map and sessions: packed with range_step
/// `pack_step` (m) and bearing_step pack_step / 50 m (the same error across at 50 m), or, with
/// pack_step 0, as they are (CompactScan: the same values), bearings shared with `before`'s.
std::shared_ptr<const CompactScan> mapScanAtRest(const Scan& scan, double pack_step, const CompactScan* before);

/// "" when `pack_step` is one mapScanAtRest takes (0, or finite and > 0), else why not.
std::string checkMapScanStep(double pack_step);

}  // namespace llc
