// Several robots, one map (issue 64; ../shared/ARCHITECTURE.md, "trajectories"). Each robot is
// a trajectory: its own SlamPipeline (front end, loops within its own run, a back end in its
// own odometry frame). Robot 0 defines the map. A robot not yet in the map searches every
// new keyframe against the keyframes of the robots in it with no pose prior (aligned,
// shape-validated and context-checked, each end's context from its own robot's odometry), and
// TrajectoryJoin joins it once the loops of several of its keyframes agree (the same rule as
// localisation: one look-alike never places a robot); a robot in the map searches the keyframes
// of those not yet in it the same way, so one that drove somewhere first is joined when a
// mapped robot passes there later. Two robots not yet in the map that agree on each other are
// linked, and follow each other in. Until then a robot maps in its own frame and nothing of it
// touches the map. Once joined, its keyframes, odometry and own loops enter the
// map's graph (one back end, one chain per robot), and its cross-robot candidates meet the map's
// place gate and its loops the map's chi-square gate, like any loop.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "laser_loop_closure/core/slam/session_io.hpp"
#include "laser_loop_closure/core/slam/slam_pipeline.hpp"
#include "laser_loop_closure/core/slam/trajectory_join.hpp"

namespace llc {

struct MultiRobotOptions {
  /// Classifier candidates of each other robot in the map aligned per new keyframe (no pose
  /// prior), before and after joining.
  std::size_t cross_candidates = 5;
  std::size_t search_threads = 2;  ///< threads aligning those candidates
  TrajectoryJoinOptions join{};    ///< when the loops of several keyframes join a robot to the map
  [[nodiscard]] std::string validate() const;
};

/// A keyframe of the map's graph: which robot's, and its index in that robot's pipeline.
struct RobotKeyframe {
  std::size_t robot = 0;
  std::size_t keyframe = 0;
};

/// A loop between two robots' keyframes as the map's back end met it (map indices in
/// record.loop.from / to).
struct CrossRobotLoop {
  RobotKeyframe from, to;
  LoopRecord record;
  bool joining = false;  ///< one of the loops that joined robot `to.robot` to the map
};

/// What one scan of one robot did.
struct RobotStep {
  SlamStepResult slam;               ///< in the robot's own pipeline
  std::size_t cross_aligned = 0;     ///< when a keyframe: other robots' keyframes aligned with it
  std::size_t cross_not_aligned = 0;  ///< candidates the map's place gate kept from alignment (a joined robot's)
  std::size_t cross_validated = 0;   ///< of those, shape-validated
  std::size_t cross_refused_by_context = 0;  ///< of those, refused by the context check (loops/context), each robot's from its own chain
  std::size_t cross_applied = 0;     ///< of those, applied to the map (joined robots)
  bool joined_now = false;           ///< this keyframe joined the robot to the map
  /// Robots this keyframe joined to the map: itself (joined_now), or robots not yet in it
  /// whose keyframes this joined robot's keyframe found, once enough of theirs agreed.
  std::vector<std::size_t> joined_robots;
  TrajectoryJoinResult join;         ///< when a keyframe of a robot not yet joined: whether it joined, or why not
};

struct MultiRobotCounters {
  std::size_t robots_joined = 0;         ///< robot 0 included
  std::size_t cross_aligned = 0, cross_validated = 0;
  std::size_t cross_not_aligned = 0;  ///< candidates of joined robots the map's place gate kept from alignment
  std::size_t cross_refused_by_context = 0;  ///< shape-validated, then refused by the context check
  std::size_t cross_robot_loops = 0;     ///< applied to the map (the joining ones included)
  /// Pairs of robots, neither in the map, whose loops agreed: when one joins, the other follows.
  std::size_t robot_links = 0;
  std::size_t cross_refused_by_gate = 0;  ///< shape-validated between joined robots, refused by the map's gate
  double seconds_search = 0.0;           ///< in the cross-robot search
};

class MultiRobotSlam {
 public:
  /// Throws std::invalid_argument on bad options, robots == 0, or a model the extractor cannot serve.
  /// With `saved_map` (a session: yesterday's map of the fleet), robot 0 is that map: it has no
  /// scans of its own (addScan, addKeyframe and addLoop refuse it), its keyframes keep their
  /// robots in session(), and robots 1 .. robots - 1 are the live ones, each joining it as any
  /// robot joins robot 0's map (no pose prior). Throws std::invalid_argument when the session
  /// cannot be restored (and robots < 2 with one).
  MultiRobotSlam(const ClassifierModel& model, std::size_t robots, const SlamOptions& slam = {},
                 const MultiRobotOptions& options = {}, const SlamSession* saved_map = nullptr);
  MultiRobotSlam(const MultiRobotSlam&) = delete;  // its joins ask this object's map
  MultiRobotSlam& operator=(const MultiRobotSlam&) = delete;

  /// Feeds one scan of `robot` (base frame) with its wheel-odometry pose in that robot's own
  /// odometry frame when there is one; nothing of it is taken as a position in the map. Never
  /// throws on bad data (SlamPipeline::addScan); std::out_of_range for an unknown robot.
  RobotStep addScan(std::size_t robot, const Scan& scan, std::size_t scan_index, const Pose2* wheel_odometry);

  /// A keyframe of `robot` that its own front end made elsewhere (its loop_closure nodelet,
  /// over the network): what addScan does once that robot's front end made it. Its own loops
  /// come by addLoop. Never throws on bad data; std::out_of_range for an unknown robot.
  RobotStep addKeyframe(std::size_t robot, Keyframe keyframe, const std::vector<double>& features,
                        const OdometryStep& odometry);
  /// A loop the robot's own front end found between two of its keyframes already added: into
  /// its own graph, and into the map's when it is joined (else with the robot when it joins).
  /// std::out_of_range for an unknown robot.
  LoopRecord addLoop(std::size_t robot, const LoopClosure& loop);

  /// The robot's own graph's answers to its front end's place gate and nearby candidates (what
  /// its pipeline asks in addScan; a front end elsewhere asks them over the network). Keyframe
  /// indices are the robot's own; std::out_of_range for an unknown robot or keyframe.
  double placeChi2(std::size_t robot, std::size_t from, std::size_t to, double radius) {
    return robots_.at(robot)->backEnd().placeChi2(from, to, radius);
  }
  std::vector<NearbyKeyframe> nearbyKeyframes(std::size_t robot, std::size_t index, std::size_t before,
                                              double max_distance, double max_std, std::size_t count) {
    return robots_.at(robot)->backEnd().nearbyKeyframes(index, before, max_distance, max_std, count);
  }

  std::size_t robots() const { return robots_.size(); }
  /// Whether the robot's keyframes are in the map (robot 0 always, once it has one).
  bool joined(std::size_t robot) const { return robot < state_.size() && state_[robot].joined; }
  /// The robot's own run: keyframes, poses in its own frame, its loops.
  const SlamPipeline& robot(std::size_t robot) const { return *robots_.at(robot); }
  /// The map's graph: every joined robot's keyframes (in the order they entered) in robot 0's frame.
  const SlamBackEnd& map() const { return map_; }
  /// Whose keyframe the map's keyframe `index` is.
  const RobotKeyframe& mapKeyframe(std::size_t index) const { return map_keyframes_.at(index); }
  /// The map index of a joined robot's keyframe; throws std::out_of_range when not in the map.
  std::size_t mapIndex(std::size_t robot, std::size_t keyframe) const;
  /// Every scan the robot used, placed in the map frame when joined(robot), else in the
  /// robot's own frame (its own pipeline's poses).
  std::vector<ScanPose> scanPoses(std::size_t robot) const;
  const std::vector<CrossRobotLoop>& crossLoops() const { return cross_loops_; }
  const MultiRobotCounters& counters() const { return counters_; }
  /// The map as a session (its keyframes, features, graph and loops, and each keyframe's robot
  /// in SlamSession::robots): what `llc localize` and `llc slam --load-session` take. Robots
  /// not yet joined are not in it. With a saved map, its keyframes keep their robots and the
  /// live robot r is robot (the saved map's largest) + r.
  SlamSession session() const;
  /// Whether robot 0 is a saved map (the constructor's saved_map).
  bool hasSavedMap() const { return !saved_robots_.empty(); }
  /// The robot id session() writes for the map keyframe of (robot, keyframe).
  std::uint32_t sessionRobot(std::size_t robot, std::size_t keyframe) const;
  /// m of path by the robot's own odometry when it joined (only when joined; robot 0: 0).
  double joinedAtPath(std::size_t robot) const { return state_.at(robot).joined_at_path; }
  const MultiRobotOptions& options() const { return options_; }

 private:
  /// Per robot: what its own pipeline does not keep, reset as one per robot.
  struct RobotState {
    bool joined = false;
    double path = 0.0;                   ///< m; its own odometry path length
    std::vector<double> paths;           ///< that length at each keyframe
    double joined_at_path = 0.0;
    std::vector<Pose2> chain;            ///< each keyframe in its own odometry frame (the front end's steps composed)
    std::vector<OdometryStep> steps;     ///< each keyframe's step from the one before (the first's unused)
    std::vector<LoopClosure> own_loops;  ///< shape-validated loops within its own run, as they came
    std::vector<std::size_t> map_index;  ///< when joined: each keyframe's index in the map
    std::vector<LoopClosure> joining_loops;  ///< loops offered to the join, parallel to its hypotheses' order of offer
  };

  /// The robot's newest keyframe (in its pipeline, step.slam) with the loops its own front end
  /// accepted: its chain, the map when joined, then the cross-robot searches and joins.
  void keyframeAdded(std::size_t robot, const std::vector<LoopClosure>& own_loops, RobotStep& step);
  /// A new keyframe as the cross-robot searches take it.
  struct Query {
    std::vector<double> features;
    const PreparedScan* scan = nullptr;
    std::size_t keyframe = 0;
  };
  /// The keyframe against robot `other`'s keyframes with no pose prior (`check`, when given,
  /// asked before each alignment): the shape-validated loops (from = other's keyframe, to = the
  /// query's), counted in `step`.
  std::vector<LoopClosure> validatedLoops(const Query& query, std::size_t other, const CandidateCheck& check,
                                          RobotStep& step) const;
  /// The context check of a loop from a keyframe of `from_robot` to one of `to_robot`, each
  /// context from its own robot's odometry; false (refused in place, counted) when it fails.
  bool contextHolds(std::size_t from_robot, LoopClosure& loop, std::size_t to_robot, RobotStep& step) const;
  /// The robot's keyframe against every other joined robot's keyframes: the loops that passed
  /// the context check (from = the other robot's keyframe in its own pipeline, to = this keyframe).
  std::vector<std::pair<std::size_t, LoopClosure>> searchOthers(std::size_t robot, const Query& query, RobotStep& step);
  /// A loop between two robots' keyframes, each index its own robot's.
  struct RobotLoop {
    std::size_t from_robot = 0, to_robot = 0;
    LoopClosure loop;
  };
  /// Two robots, neither in the map when their loops agreed (TrajectoryJoin of one's frame in
  /// the other's): the loops that agreed. When one of them joins, the other follows through them.
  struct Link {
    std::size_t a = 0, b = 0;
    std::vector<RobotLoop> loops;
  };
  /// A robot not yet in the map: its keyframe against the keyframes of every other robot not
  /// yet in it; the loops of each pair meet a TrajectoryJoin of their own, and agreeing ones
  /// make a Link.
  void searchPeers(std::size_t robot, const Query& query, RobotStep& step);
  /// The joining loops of a join to the map (its supporting hypotheses' loops), each robot's indices.
  std::vector<RobotLoop> loopsOfJoin(std::size_t robot, const TrajectoryJoinResult& join) const;
  /// Every robot linked to `robot` (now joined) and not in the map joins through its link.
  void joinLinked(std::size_t robot, RobotStep& step);
  /// A joined robot's keyframe against the keyframes of every robot not yet in the map: each
  /// loop found is aligned again the other way round (the other robot's keyframe seen from
  /// this one's), context-checked, and offered to that robot's join.
  void searchUnjoined(std::size_t robot, const Query& query, RobotStep& step);
  /// A shape-validated, context-checked loop from map keyframe loop.from to keyframe loop.to
  /// of a robot not yet joined: offered to its join as a hypothesis (returned).
  JoinHypothesis joinHypothesis(std::size_t robot, const LoopClosure& loop);
  /// How far the map may be off between two of its keyframes: kMapSigmas standard deviations of
  /// their relative pose (Esdf::relativePose; none when the map cannot say).
  MapAllowance mapAllowance(std::size_t map_a, std::size_t map_b);
  /// Enters keyframe `keyframe` of a joined robot into the map, linked from its previous one.
  void enterKeyframe(std::size_t robot, std::size_t keyframe);
  /// A loop between two keyframes that are both in the map (own or cross-robot) to its back end.
  LoopRecord applyToMap(std::size_t from_robot, const LoopClosure& loop, std::size_t to_robot, bool joining = false);
  /// Robot `robot` joins: its keyframes so far (the first where map_from_trajectory puts it,
  /// loosely linked to map keyframe `anchor`), its own loops and the loops that joined it; then
  /// the robots linked to it.
  void joinRobot(std::size_t robot, const Pose2& map_from_trajectory, std::size_t anchor, const std::vector<RobotLoop>& loops,
                 RobotStep& step);
  /// Throws std::invalid_argument when `robot` is 0 and robot 0 is a saved map.
  void refuseSavedMap(std::size_t robot) const;
  /// The context check's view of a robot's keyframes (its front end's odometry chain).
  KeyframeContext contextOf(std::size_t robot) const;

  MultiRobotOptions options_;
  PlaceGateOptions place_gate_;  ///< the pipeline's, asked before a joined robot's cross-robot candidate is aligned
  std::vector<std::unique_ptr<SlamPipeline>> robots_;
  std::vector<RobotState> state_;
  std::vector<TrajectoryJoin> joins_;
  SlamBackEnd map_;
  std::vector<RobotKeyframe> map_keyframes_;
  std::vector<CrossRobotLoop> cross_loops_;
  MultiRobotCounters counters_;
  /// Robots neither in the map: (u, v) -> u's frame in v's odometry frame, and the loops offered
  /// to it (from = v's keyframe, to = u's); erased once the pair is linked.
  std::map<std::pair<std::size_t, std::size_t>, TrajectoryJoin> peer_joins_;
  std::map<std::pair<std::size_t, std::size_t>, std::vector<LoopClosure>> peer_loops_;
  std::vector<Link> links_;
  /// With a saved map (robot 0): each of its keyframes' robot as the session had it; empty without.
  std::vector<std::uint32_t> saved_robots_;
};

}  // namespace llc
