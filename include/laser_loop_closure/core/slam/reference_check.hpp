// Whether a reference ("ground truth") pose is itself contradicted by the scans. The
// SLAM-corrected logs used as truth hold glitches (csail's scans 397-399 are turned about 11
// degrees against their neighbours), and a loop judged wrong against such a pose may be right.
#pragma once

#include <cstddef>
#include <vector>

#include "laser_loop_closure/core/alignment/scan_aligner.hpp"
#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc {

struct ReferenceCheckOptions {
  double min_turn = 0.05;     ///< rad; ICP from the reference's relative pose turning more says it is off
  double min_fit_gain = 0.1;  ///< ... when it also fits the scans better by this much (ScanAligner::fit, 0..1)
};

/// A neighbouring scan and its reference pose.
struct ReferenceNeighbour {
  const PreparedScan* scan = nullptr;
  Pose2 truth;
};

/// One side of the check: the neighbour whose ICP, started from the reference's relative pose,
/// turned the most among those that contradict it (or, when none does, the most of all).
struct ReferenceSide {
  bool contradicts = false;  ///< some neighbour on this side: turn > min_turn and fit_gain >= min_fit_gain
  double turn = 0.0;         ///< rad; how far that ICP turned away from the reference's relative pose
  double fit_gain = 0.0;     ///< fit at ICP's pose minus fit at the reference's
};

struct ReferenceCheck {
  ReferenceSide before, after;
  bool contradicted = false;  ///< both sides contradict the reference pose of `at`
};

/// The reference pose of scan `at` against neighbours before and after it (the nearest few
/// keyframes on either side): contradicted when on both sides some neighbour's ICP, started
/// from the reference's relative pose, turns by more than min_turn and fits the scans better
/// by min_fit_gain. Both sides, because a glitch of neighbours alone makes only their side
/// disagree; a few on each side, because a glitch spans a few scans (csail's three), whose
/// pairs among themselves agree.
ReferenceCheck checkReferencePose(const ScanAligner& aligner, const PreparedScan& at, const Pose2& truth_at,
                                  const std::vector<ReferenceNeighbour>& before,
                                  const std::vector<ReferenceNeighbour>& after, const ReferenceCheckOptions& options = {});

/// Which scans of a drive checkReferencePose takes as `at`'s neighbours, by their reference
/// poses: walking away from `at` on either side, each next one at least `spacing_m` m or
/// `spacing_rad` rad from the one taken before (spaced as keyframes are), up to `count` a
/// side, none farther than `max_distance` m from `at` (beyond, a kidnapping's jump or too
/// little overlap to tell). Nearest first.
struct ReferenceNeighbourIndices {
  std::vector<std::size_t> before, after;
};
ReferenceNeighbourIndices referenceNeighbourIndices(const std::vector<Pose2>& truth, std::size_t at, double spacing_m = 1.0,
                                                    double spacing_rad = 0.35, std::size_t count = 3,
                                                    double max_distance = 5.0);

}  // namespace llc
