// Ground truth for a log from another log of the same drive: the benchmark's raw logs carry
// only wheel odometry, while the SLAM-corrected logs of the same buildings hold corrected poses
// for a subset of the very same scans. Scans are paired by their ranges, which are identical.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "laser_loop_closure/core/io/scan_sequence.hpp"

namespace llc {

struct ReferenceTruthResult {
  std::size_t matched = 0;          ///< scans given the reference's pose of the identical scan
  std::size_t carried = 0;          ///< scans given a pose carried by odometry from matched scans
  std::size_t ambiguous = 0;        ///< reference scans left out: their ranges occur twice (either log)
  std::size_t max_carry_scans = 0;  ///< most scans between any scan and its nearest matched scan
  std::size_t stalled_odometry = 0;  ///< scans whose odometry reading was stalled: interpolated to carry by
  std::vector<bool> matched_scans;  ///< per scan of the sequence: whether it took a reference pose
  /// Per scan of the sequence: how far its odometry, carried across the gap the scan lies in
  /// from the matched scan before it to the one after, misses the reference's pose there (m,
  /// rad). A carried pose can be off by up to that much; 0 for a matched scan and NaN before
  /// the first or after the last one (not known).
  std::vector<double> gap_miss_m, gap_miss_rad;
};

/// Replaces every scan's truth in `sequence`: a scan whose ranges (to 1 cm, same beam count; as
/// recorded when both logs kept them, so that scanner offsets and rear scans do not matter)
/// equal those of exactly one scan of `reference` (and of no other scan of `sequence`) takes
/// that scan's truth. Any other scan is carried by its odometry motion from the matched scans
/// on either side (by index): from each one's truth, the two blended linearly by the scan's
/// place between them (the heading along the shorter arc); before the first or after the last
/// matched scan from that one alone. A stalled odometry reading (repeated exactly, then a
/// different one within 2 s) is interpolated in time between the readings around it first. Throws std::invalid_argument (the sequence unchanged) when
/// fewer than two scans match: then it is not the same drive.
ReferenceTruthResult applyReferenceTruth(const ScanSequence& reference, ScanSequence* sequence);

}  // namespace llc
