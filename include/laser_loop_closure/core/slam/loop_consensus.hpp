// Loops the back end's chi-square gate refused, kept until several agree (pairwise
// consistency, as in PCM: Mangelson et al. 2018). The gate weighs one loop against the map;
// when a keyframe step is wrong beyond its covariance (a laser-only step that slid metres along
// a corridor), every true loop over it misses the map by the same amount, and the gate refuses
// them one by one. Several refused loops that tell the same story about the same two stretches
// of the drive are applied together. A loop that misses the map by far (a corridor's mirror
// image, turned by 180 degrees: chi-square 300 and more on ACES laser-only) never joins: such
// look-alikes agree among themselves as well (scripts/lib/loop_consensus.py).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "laser_loop_closure/core/geometry/se2.hpp"
#include "laser_loop_closure/core/slam/slam_types.hpp"

namespace llc {

struct LoopConsensusOptions {
  std::size_t min_loops = 4;             ///< this many refused loops that agree are applied together, the newest included (0: off)
  double max_chi2 = 80.0;                ///< a refused loop whose innovation chi-square is above this is not kept (3 DoF; the gate is esdf/loop_chi2_threshold)
  std::size_t max_keyframes_apart = 30;  ///< two loops are compared when their older ends and their newer ends are each at most this many keyframes apart
  double max_translation = 0.3;          ///< m; two loops agree when the cycle through both and the map between their ends closes within this ...
  double max_rotation = 0.05;            ///< rad; ... and this
  std::size_t max_kept = 1000;           ///< refused loops kept at most (the oldest forgotten first)
  [[nodiscard]] std::string validate() const;
};

/// One refused loop offered to the consensus.
struct LoopConsensusResult {
  bool kept = false;                ///< joined the refused loops waiting (chi-square within max_chi2, consensus on)
  std::vector<std::size_t> group;   ///< ids of the loops to apply now, this one included; empty unless min_loops agree
};

class LoopConsensus {
 public:
  /// Throws std::invalid_argument on bad options.
  explicit LoopConsensus(const LoopConsensusOptions& options = {});

  /// A loop the gate refused with `chi2`, named `id` by the caller (its record), weighed
  /// against the loops kept so far at the current keyframe `poses`. When it and at least
  /// min_loops - 1 kept ones agree (each with it), returns them all and forgets them.
  LoopConsensusResult offer(std::size_t id, const LoopClosure& loop, double chi2, const std::vector<Pose2>& poses);
  /// Keeps a refused loop without weighing it (a restored session's); false if it may not wait
  /// (consensus off, chi-square above max_chi2, pose not finite).
  bool keep(std::size_t id, const LoopClosure& loop, double chi2);
  /// Whether two loops agree at `poses`: their older ends and newer ends each within
  /// max_keyframes_apart, and a's pose, then the map from a's newer end to b's, closes onto the
  /// map from a's older end to b's, then b's pose, within max_translation and max_rotation.
  bool agree(const LoopClosure& a, const LoopClosure& b, const std::vector<Pose2>& poses) const;
  std::size_t kept() const { return kept_.size(); }
  void clear() { kept_.clear(); }
  const LoopConsensusOptions& options() const { return options_; }

 private:
  /// Consensus on, chi-square within max_chi2 (false for NaN), pose finite.
  bool mayWait(const LoopClosure& loop, double chi2) const;
  struct Kept {
    std::size_t id;
    LoopClosure loop;
  };
  LoopConsensusOptions options_;
  std::vector<Kept> kept_;
};

}  // namespace llc
