// Is the wheel odometry of a drive in step with its scans? Consecutive scans are aligned by
// ICP seeded by the odometry of the same scans shifted by each candidate offset; the offset
// whose seeds ICP has to correct least, on average, is the one in step. (An average, not a
// median: at steady speed every offset predicts the same step, and only turns and changes of
// speed tell them apart.) Some logs write each pose one
// scan early or late (the raw Intel log), which bends every map made from them.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "laser_loop_closure/core/alignment/scan_aligner.hpp"
#include "laser_loop_closure/core/slam/scan_odometry.hpp"
#include "laser_loop_closure/core/io/scan_sequence.hpp"

namespace llc {

struct OdometryOffsetOptions {
  int max_offset = 3;            ///< scans; offsets -max_offset..max_offset are tried
  std::size_t max_pairs = 300;   ///< consecutive scan pairs used at most (evenly spread)
  double min_motion = 0.05;      ///< m or rad the odometry moved between the two scans; stiller pairs tell nothing
  [[nodiscard]] std::string validate() const;
};

/// How well the odometry shifted by `offset` predicts the scans' own motion.
struct OdometryOffsetScore {
  int offset = 0;
  std::size_t pairs = 0;                 ///< pairs tried
  std::size_t matched = 0;               ///< ICP converged, near its seed and overlapping
  double mean_correction_m = 0.0;        ///< of the matched pairs: how far ICP moved the seed
  double mean_correction_rad = 0.0;      ///< and how far it turned it
  std::vector<double> correction_rad;    ///< per pair (NaN: not matched), for the paired test
};

struct OdometryOffsetResult {
  bool ok = false;                       ///< the scans could tell (best_offset may still be 0)
  int best_offset = 0;                   ///< the smallest mean_correction_rad (ties: nearest 0)
  std::vector<OdometryOffsetScore> scores;  ///< one per offset, -max_offset first
  /// Why not ok (no odometry, too few moving pairs), or why best_offset: its mean correction
  /// against offset 0's and the paired t statistic of the difference (how clearly the scans
  /// tell them apart; on the benchmark logs 1.8 to 3.6 where an offset other than 0 won).
  std::string reason;
};

/// Needs sequence.has_odometry. Throws std::invalid_argument on bad options only.
OdometryOffsetResult estimateOdometryOffset(const ScanSequence& sequence, const ScanOdometry& odometry,
                                            const ScanAligner& aligner, const OdometryOffsetOptions& options = {});

/// Shared by estimateOdometryOffset and OdometryTimeOffsetProbe: one pair's ICP from `guess`
/// (the odometry's motion between the two scans) counted into `score`.
void addOffsetPair(const OdometryStep& step, const Pose2& guess, OdometryOffsetScore* score);
/// The scores' means (after every addOffsetPair), the best offset and why: sets result->ok,
/// best_offset and reason (`unit` follows each offset in the reason, e.g. " scans").
void pickBestOffset(OdometryOffsetResult* result, const std::string& unit);

}  // namespace llc
