// A recorded drive as the offline tools see it: one scan per front scan of the input, with
// its ground-truth pose (for labelling) and odometry.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "laser_loop_closure/core/io/carmen_reader.hpp"
#include "laser_loop_closure/core/geometry/scan.hpp"
#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc {

struct LoggedScan {
  Scan scan;       ///< in the robot's base frame; 360 degrees when a rear scan was merged
  Pose2 truth;     ///< TRUEPOS when the log has it, else the pose on the laser line
  Pose2 odometry;  ///< odometry pose on the laser line
  double stamp = 0.0;
  Pose2 front_mount;  ///< the front scanner's pose in the base frame (identity: it is the base)
  /// recordedRangesKey of the front scanner's ranges as the log wrote them (before any mount
  /// or merge), which names the scan in other logs of the same drive; 0 when not known.
  std::uint64_t recorded_ranges_key = 0;
};

struct ScanSequence {
  std::string source;  ///< the file it came from
  std::vector<LoggedScan> scans;
  std::size_t merged_count = 0;  ///< how many scans got a rear scan merged in
  bool has_odometry = true;  ///< false: the input had no odometry (the odometry poses are all zero)
};

struct ScanSequenceOptions {
  bool use_rear = true;       ///< merge a rear scan into its front scan when there is one
  double max_merge_gap = 0.05;  ///< s; a rear scan further in time from the front one is unused
};

/// A hash of ranges to 1 cm (a range that is not finite as one value of its own) and their
/// count; never 0.
std::uint64_t recordedRangesKey(const std::vector<double>& ranges);

/// One scan per front laser line (FLASER or ROBOTLASER1), index = position among them.
/// A rear (RLASER) line written next to a front line and within max_merge_gap of it is
/// merged into a 360-degree scan, the rear scanner mounted at (rear_offset, 0, pi).
ScanSequence makeScanSequence(const CarmenLog& log, const ScanSequenceOptions& options = {});

/// Reads any supported log by its name (.log / .log.gz / other text: CARMEN).
/// Throws std::runtime_error with a clear message on failure.
ScanSequence loadScanSequence(const std::string& path, const ScanSequenceOptions& options = {});

/// Pairs each scan with the odometry pose of the scan `offset` places later (negative:
/// earlier), for drives whose odometry was written out of step with the laser (the raw Intel
/// log needs -1: its poses run one scan ahead). Beyond either end the nearest pose repeats.
/// Only the odometry moves; the truth stays where it was.
void shiftOdometry(ScanSequence* sequence, int offset);

}  // namespace llc
