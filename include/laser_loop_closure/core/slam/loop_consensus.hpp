// Loops the chi-square gate refused, applied after all when several agree. The gate compares
// a loop with where the map puts its two keyframes; when the odometry between them is wrong
// by more than its covariance says (a wheel fault, a poorly matched turn), every true loop there
// is refused alike, and the part of the map stays unmended. Such loops agree with one another
// through the short odometry between their ends, which a single wrong loop does not (pairwise
// consistency, as Mangelson et al.'s PCM, 2018, tests it). min_loops of them that all agree
// pairwise are applied together, without the gate.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <string>
#include <vector>

#include "laser_loop_closure/core/backend/esdf.hpp"
#include "laser_loop_closure/core/slam/slam_types.hpp"

namespace llc {

struct LoopConsensusOptions {
  bool enabled = false;                ///< true: loops the gate refused may pass together; off: it let aliased groups pass (docs/benchmark.md)
  std::size_t min_loops = 3;           ///< loops, all pairwise consistent, that together pass (the newest among them)
  std::size_t max_keyframe_span = 10;  ///< keyframes; two loops are compared only when both their ends lie this near
  double pair_chi2 = 11.34;            ///< chi2 (3 DoF, 99%) of one loop predicted from the other, above which they disagree
  std::size_t max_held = 50;           ///< refused loops kept for comparison (the oldest dropped first)
  std::string validate() const;
};

/// Chi-square statistic (3 DoF) of loop `second` against its prediction from loop `first`
/// through the map's relative poses of their older ends (second.from -> first.from) and of
/// their newer ends (first.to -> second.to), with all four covariances propagated to first
/// order. Small when both loops say the same about how the two parts of the map lie.
double loopPairChi2(const LoopClosure& first, const LoopClosure& second, const Pose2& older_ends,
                    const Eigen::Matrix3d& older_ends_covariance, const Pose2& newer_ends,
                    const Eigen::Matrix3d& newer_ends_covariance);

class LoopConsensus {
 public:
  explicit LoopConsensus(const LoopConsensusOptions& options = {});
  const LoopConsensusOptions& options() const { return options_; }
  /// Keeps a loop the gate refused; record is the caller's handle for it (returned by agree()).
  void hold(const LoopClosure& loop, std::size_t record);
  /// For a loop the gate refused just now: the handles of held loops that, with it, make a set
  /// of at least min_loops pairwise consistent loops (empty when there is none). Those are no
  /// longer held; the new loop is not held by this call. Relative poses come from the filter.
  std::vector<std::size_t> agree(const LoopClosure& loop, Esdf& esdf);
  std::size_t held() const { return held_.size(); }

 private:
  struct Held {
    LoopClosure loop;
    std::size_t record;
  };
  bool near(const LoopClosure& a, const LoopClosure& b) const;
  bool consistent(const LoopClosure& a, const LoopClosure& b, Esdf& esdf) const;
  LoopConsensusOptions options_;
  std::vector<Held> held_;
};

}  // namespace llc
