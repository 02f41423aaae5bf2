// Loops against ground truth: which keyframes truly revisit a place, how many of them a run
// closed, and which applied loops are wrong. `llc slam --evaluate` and the bag rostest share it.
#pragma once

#include <cstddef>
#include <vector>

#include "laser_loop_closure/core/slam/slam_types.hpp"

namespace llc {

struct LoopTruthOptions {
  std::size_t min_keyframe_gap = 30;  ///< keyframes; nearer ones are not a revisit (as the detector's)
  double positive_distance = 1.5;     ///< m; a revisit is this near an older keyframe ...
  double positive_heading = 0.785398163397448;  ///< rad; ... and turned less than this (partial scans only)
  double wrong_translation = 1.0;     ///< m; an applied loop farther off the truth is wrong
  double wrong_rotation = 0.1;        ///< rad; likewise for its heading
};

struct LoopTruthCheck {
  std::size_t true_loop_keyframes = 0;  ///< keyframes with a true revisit
  std::size_t closed = 0;               ///< of those, closed by a right applied loop
  std::size_t applied = 0, wrong_loops = 0;
  double loop_nees = 0.0;  ///< mean e^T C^-1 e of the applied loops (3 when C is honest)
};

/// truth[k] and full_circle[k] belong to keyframe k; loops as the back end met them (only
/// applied ones count). Loops naming keyframes beyond truth are ignored.
LoopTruthCheck checkLoopsAgainstTruth(const std::vector<Pose2>& truth, const std::vector<bool>& full_circle,
                                      const std::vector<LoopRecord>& loops, const LoopTruthOptions& options = {});

/// Where each true-revisit keyframe that no right loop closed was lost: the furthest stage
/// that one of its true candidates (a candidate pair that is a true revisit) reached.
struct RevisitFates {
  std::size_t open = 0;                 ///< true-revisit keyframes not closed (the sum of the rest)
  std::size_t no_true_candidate = 0;    ///< the classifier (or its top max_candidates) offered no true pair
  std::size_t place_gate = 0;           ///< true candidates offered, all skipped before alignment
  std::size_t alignment = 0;            ///< a true candidate aligned, refused by alignment or validation
  std::size_t back_end_gate = 0;        ///< a true candidate accepted by alignment, refused by the chi2 gate
  std::size_t wrong_pose = 0;           ///< a true candidate applied, but its pose off the truth (a wrong loop)
};

/// The fates of the true-revisit keyframes of checkLoopsAgainstTruth that were not closed, from
/// every loop the back end met and the candidates skipped before alignment (not_aligned).
RevisitFates revisitFates(const std::vector<Pose2>& truth, const std::vector<bool>& full_circle,
                          const std::vector<LoopRecord>& loops, const std::vector<LoopClosure>& not_aligned,
                          const LoopTruthOptions& options = {});

/// How many of these pairs (from, to: keyframes) are true revisits by the same test as
/// true_loop_keyframes (distance, and heading for partial scans; the gap is not asked).
/// Pairs naming keyframes beyond truth are ignored.
std::size_t countTrueRevisitPairs(const std::vector<Pose2>& truth, const std::vector<bool>& full_circle,
                                  const std::vector<LoopClosure>& pairs, const LoopTruthOptions& options = {});

}  // namespace llc
