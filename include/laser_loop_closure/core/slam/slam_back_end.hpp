// The back end of ../shared/ARCHITECTURE.md: keyframes with their odometry constraints and the
// loop closures a front end found go into the ESDF (chi-square gate on each loop); it knows
// the optimised keyframe poses and map -> odom. The esdf_backend nodelet runs it alone;
// SlamPipeline joins it to the front end directly.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "laser_loop_closure/core/backend/esdf.hpp"
#include "laser_loop_closure/core/slam/loop_consensus.hpp"
#include "laser_loop_closure/core/slam/slam_types.hpp"
#include "laser_loop_closure/core/geometry/scan.hpp"

namespace llc {

struct BackEndCounters {
  std::size_t keyframes = 0;
  std::size_t loosely_linked_keyframes = 0;  ///< kept, but their odometry was unusable (see addKeyframe)
  std::size_t loops_accepted = 0;     ///< applied
  std::size_t refused_by_gate = 0;    ///< the chi-square test said no (and no consensus applied it later)
  std::size_t applied_by_consensus = 0;  ///< of loops_accepted, refused by the gate, then applied with others that agree (LoopConsensus)
  std::size_t refused_loops = 0;      ///< malformed: unknown keyframes, bad covariance
  double seconds = 0.0;
};

/// Covariance of a link that says next to nothing: anywhere within ~100 m, any heading, so
/// that the first loop closure places the keyframe. Not looser, so that the information matrix
/// stays well conditioned next to the first pose's prior. Used for a new chain after a
/// restored session and for a keyframe whose odometry is unusable.
Eigen::Matrix3d looseLinkCovariance();

class SlamBackEnd {
 public:
  /// Throws std::invalid_argument on bad options.
  explicit SlamBackEnd(const EsdfOptions& options = {}, bool gate_loops = true, const LoopConsensusOptions& consensus = {});

  /// Appends keyframe number keyframes().size() with its motion from the previous keyframe
  /// (ignored for the first, which sits at its wheel-odometry pose, or the origin). Always
  /// appends: the keyframe's index must stay the front end's, and its scan is data. Returns ""
  /// or what was unusable and what was done instead: a motion that is not finite, or a
  /// covariance not positive definite or beyond EsdfOptions::max_information, is replaced by a
  /// loose link (the motion when finite, else none, with looseLinkCovariance());
  /// non-finite wheel odometry is dropped (has_wheel_odometry false).
  std::string addKeyframe(Keyframe keyframe, const Pose2& motion, const Eigen::Matrix3d& covariance);
  /// The same with the motion from keyframe `base` instead of the previous one: a graph that
  /// holds several robots' chains (MultiRobotSlam's map). Throws std::out_of_range for a base
  /// it does not have (a caller's bug, not data).
  std::string addKeyframeFrom(std::size_t base, Keyframe keyframe, const Pose2& motion, const Eigen::Matrix3d& covariance);
  /// A loop between two stored keyframes (from older than to), through the gate when
  /// gate_loops. The record says whether it was applied and why not; never throws on data.
  /// One the gate refused is offered to the consensus (LoopConsensus): when enough refused
  /// loops agree with it, all are applied without the gate, and lastConsensus() names them.
  LoopRecord addLoop(const LoopClosure& loop);
  /// Indices into loops() of the loops the last addLoop applied by consensus (that loop's
  /// own last), their records updated (applied, by_consensus); empty if it applied none so.
  const std::vector<std::size_t>& lastConsensus() const { return last_consensus_; }

  const std::vector<Keyframe>& keyframes() const { return keyframes_; }
  /// Optimised keyframe poses in the map frame.
  const std::vector<Pose2>& poses() const;
  /// Every loop that reached the back end, in order.
  const std::vector<LoopRecord>& loops() const { return loops_; }
  const BackEndCounters& counters() const { return counters_; }
  /// map -> odom (REP-105) implied by the newest keyframe; identity without wheel odometry.
  Pose2 mapToOdom() const;
  /// Esdf::placeChi2 of two stored keyframes (counted in the back end's seconds); throws
  /// std::out_of_range for a keyframe it does not have.
  double placeChi2(std::size_t from, std::size_t to, double radius);
  /// Keyframes older than `before` whose optimised position lies within max_distance of keyframe
  /// `index`'s and whose position relative to it is known to max_std (the largest standard
  /// deviation of the relative translation), nearest first, at most `count`, each with where the
  /// map puts keyframe `index` in its frame (a NearbyKeyframes source). Throws std::out_of_range for a keyframe it does not have.
  std::vector<NearbyKeyframe> nearbyKeyframes(std::size_t index, std::size_t before, double max_distance, double max_std,
                                              std::size_t count);
  /// Marginal covariance of the newest keyframe's pose (zero when there is none).
  Eigen::Matrix3d latestCovariance();
  bool gateLoops() const { return gate_loops_; }
  Esdf* esdf() { return esdf_.get(); }
  const Esdf* esdf() const { return esdf_.get(); }

  /// Replaces everything by a saved session: the ESDF is rebuilt from its constraints in
  /// their order (augmentations, then loop updates without the gate: they passed it once) and
  /// solved from the saved poses. Returns "" or why not; then nothing changed. The loops the
  /// gate refused wait for a consensus again; those a consensus applied are counted so.
  [[nodiscard]] std::string restore(const SlamSession& session);

 private:
  /// Offers the refused loop loops_[index] to the consensus; applies the group it completes.
  void applyByConsensus(std::size_t index);

  EsdfOptions options_;
  bool gate_loops_;
  LoopConsensus consensus_;
  std::vector<std::size_t> last_consensus_;
  std::unique_ptr<Esdf> esdf_;
  std::vector<Keyframe> keyframes_;
  std::vector<LoopRecord> loops_;
  BackEndCounters counters_;
};

}  // namespace llc
