// Joining a trajectory to a map (../shared/ARCHITECTURE.md, "trajectories"): a robot that does
// not know where it is keeps its own odometry frame; each loop from one of its keyframes to a
// keyframe of the map says where that frame lies in the map. One such loop may be a look-alike
// place (a corridor, a row of doors), so the frame is joined only when the loops of several
// keyframes, placed by the trajectory's own odometry, say the same, and no other story is
// nearly as well supported. Localisation joins a robot to a saved map this way; several robots
// join each other the same way.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc {

struct TrajectoryJoinOptions {
  std::size_t min_keyframes = 3;  ///< keyframes whose loops agree before the trajectory is joined
  double min_spread = 1.0;        ///< m of the trajectory's own path between the first and last of them (not one view seen thrice) ...
  /// ... or rad of view they see together beyond what one of them sees: a scanner of less than
  /// the full circle turned on the spot sees new walls (45 degrees: views this far apart are
  /// two places to the classifier's labels, llc pairs --positive-heading-deg); 0: off.
  double min_new_view = 0.785;
  double max_translation = 0.5;   ///< m; two loops agree when one's map frame puts the other's keyframe within this ...
  double max_rotation = 0.1;      ///< rad; ... and this of where its own loop puts it
  double drift_per_metre = 0.02;  ///< m/m; the trajectory's odometry drift allowed on top of max_translation, per m of path between the two keyframes
  double drift_rad_per_metre = 0.003;  ///< rad/m; the same on top of max_rotation
  double window = 30.0;           ///< m of path; older loops are forgotten (odometry over longer stretches drifts too far)
  std::size_t min_lead = 2;       ///< the winning story must have this many more keyframes than any that contradicts it
  [[nodiscard]] std::string validate() const;
};

/// One loop from a keyframe of the trajectory to a keyframe of the map.
struct JoinHypothesis {
  std::size_t keyframe = 0;      ///< of the trajectory
  double path = 0.0;             ///< m; the trajectory's odometry path length at that keyframe
  Pose2 trajectory_pose;         ///< the keyframe in the trajectory's own frame
  Pose2 map_pose;                ///< the keyframe in the map frame, by the loop
  std::size_t map_keyframe = 0;  ///< the map keyframe the loop reached
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();  ///< the loop's (its pose's x, y, theta)
  /// rad: the keyframe's field of view (2 pi, the full circle: turned on the spot, it sees nothing new).
  double view_width = 2.0 * M_PI;
  /// m: an upper bound on the standard deviation of map_keyframe's position in the map (0: the
  /// map taken as exact there); two loops whose bounds sum small need no MapAllowance.
  double map_std = 0.0;
  /// The trajectory frame in the map frame this loop implies.
  Pose2 mapFromTrajectory() const { return compose(map_pose, inverse(trajectory_pose)); }
};

struct TrajectoryJoinResult {
  bool joined = false;
  Pose2 map_from_trajectory;          ///< when joined: from the newest loop of the winning story
  JoinHypothesis newest;              ///< when joined: that loop
  std::vector<std::size_t> support;   ///< indices into hypotheses() of the winning story (one per keyframe)
  std::size_t keyframes = 0;          ///< keyframes that support the best story so far
  std::size_t rival_keyframes = 0;    ///< keyframes that support the best story contradicting it
  /// When joined: the trajectory frame in the map by each story that contradicts the winner
  /// (its newest loop), best supported first, at most 3: places a caller may check too.
  std::vector<Pose2> rival_frames;
  std::string why_not;                ///< when not joined: what is missing
};

/// How far the map itself may be off between two of its keyframes: widens the tolerances of
/// two loops into those keyframes (a map of one robot's unclosed odometry bends by metres).
struct MapAllowance {
  double translation = 0.0;  ///< m
  double rotation = 0.0;     ///< rad
};
/// The allowance for two map keyframes (the caller decides how many standard deviations).
using MapAllowanceOf = std::function<MapAllowance(std::size_t map_keyframe_a, std::size_t map_keyframe_b)>;

class TrajectoryJoin {
 public:
  /// Throws std::invalid_argument on bad options. Without `map_allowance` the map is taken as
  /// exact (a saved map, localisation); with it (several robots: the map is live), two loops
  /// also agree within the allowance of their map keyframes, asked only when the loops' own
  /// map_std bounds (times `map_sigmas`) could reach the miss.
  explicit TrajectoryJoin(const TrajectoryJoinOptions& options = {}, MapAllowanceOf map_allowance = {}, double map_sigmas = 0.0);

  /// Adds the loops of one keyframe (any number, look-alikes included), forgets those out of
  /// the window, and says whether the trajectory can be joined now. Loops with a non-finite
  /// pose or path are left out.
  TrajectoryJoinResult offer(const std::vector<JoinHypothesis>& loops);
  /// Whether two loops tell the same story: a's map frame puts b's keyframe where b's loop
  /// does, within the tolerances grown by the drift over the path between them.
  bool agree(const JoinHypothesis& a, const JoinHypothesis& b) const;
  const std::vector<JoinHypothesis>& hypotheses() const { return kept_; }
  void clear() { kept_.clear(); }
  const TrajectoryJoinOptions& options() const { return options_; }

 private:
  /// The keyframes (distinct) of the loops that agree with loop `index`, one loop each, the
  /// nearest in path to it first; indices into kept_.
  std::vector<std::size_t> storyOf(std::size_t index) const;

  TrajectoryJoinOptions options_;
  MapAllowanceOf map_allowance_;
  double map_sigmas_ = 0.0;
  /// Allowances asked during one offer (the map does not change within it).
  mutable std::map<std::pair<std::size_t, std::size_t>, MapAllowance> allowances_;
  std::vector<JoinHypothesis> kept_;
};

}  // namespace llc
