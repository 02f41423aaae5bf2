// A planar range scan in the robot's base frame, and how beams are classified.
#pragma once

#include <cstddef>
#include <vector>

#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc {

/// One scan, beams ordered by increasing bearing. Ranges may hold anything a real sensor
/// sends (NaN, +-inf, negative, zero); the feature extractor decides what is valid.
struct Scan {
  std::vector<double> ranges;    ///< metres, from the base-frame origin
  std::vector<double> bearings;  ///< radians in the base frame, increasing
  double stamp = 0.0;            ///< seconds
  /// True when the bearings cover the full circle, so that the last beam neighbours the first.
  bool full_circle = false;

  std::size_t size() const { return ranges.size(); }
  bool empty() const { return ranges.empty(); }
};

/// Geometry of one physical 2D scanner's beams (as in sensor_msgs/LaserScan).
struct ScannerGeometry {
  double angle_min = 0.0;        ///< radians, bearing of the first beam in the scanner frame
  double angle_increment = 0.0;  ///< radians between beams
  double range_max = 0.0;        ///< metres, the scanner's own maximum (0 = unknown)
};

/// The scanner geometry the CARMEN FLASER/RLASER lines imply: n beams over 180 degrees from
/// -90 degrees, step pi/n for even n and pi/(n-1) for odd n (what the real logs show).
ScannerGeometry carmenFlaserGeometry(std::size_t beam_count);

/// Builds a scan from raw ranges of one scanner mounted at `mount` on the robot. When the
/// mount is the identity the bearings are the scanner's own; otherwise each returned point is
/// moved into the base frame and its range and bearing recomputed from the base origin
/// (beams with no return keep their ray direction and a range of +inf).
Scan scanFromRanges(const std::vector<double>& ranges, const ScannerGeometry& geometry,
                    const Pose2& mount = Pose2{}, double stamp = 0.0);

/// Options for merging a front and a back scanner into one scan.
struct ScanMergeOptions {
  /// Beams are re-sampled onto this many equally spaced bearings over 360 degrees
  /// (0 = keep every beam of both scanners, sorted by bearing).
  std::size_t output_beams = 0;
};

/// Merges the beams of two scans already expressed in the base frame into one scan sorted by
/// bearing, marked full_circle. With output_beams > 0 each output bearing keeps the nearest
/// return that falls into its angular cell (+inf when none does).
Scan mergeScans(const Scan& front, const Scan& back, const ScanMergeOptions& options = {});

/// The scan seen after the robot turned by `angle` on the spot: every bearing decreases by
/// `angle`. A full-circle scan has its bearings wrapped into [-pi, pi) and its beams put back
/// in increasing order (a cyclic shift), so any angle is exact for any beam layout.
Scan rotateScan(const Scan& scan, double angle);

}  // namespace llc
