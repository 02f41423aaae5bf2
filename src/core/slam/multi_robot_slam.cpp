#include "laser_loop_closure/core/slam/multi_robot_slam.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iterator>
#include <stdexcept>

namespace llc {
namespace {
/// Standard deviations of the map's own relative pose by which a join's tolerances widen
/// between two map keyframes (3: a miss the map's uncertainty explains 99% of the time).
constexpr double kMapSigmas = 3.0;

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

const MultiRobotOptions& checked(const MultiRobotOptions& options) {
  const std::string error = options.validate();
  if (!error.empty()) throw std::invalid_argument("multi-robot options: " + error);
  return options;
}

/// The offered loops behind a join's supporting hypotheses, in support order (a hypothesis
/// names its loop by the keyframe it joins and the keyframe it reached).
std::vector<LoopClosure> supportingLoops(const TrajectoryJoin& join, const TrajectoryJoinResult& result,
                                         const std::vector<LoopClosure>& offered) {
  std::vector<LoopClosure> loops;
  for (std::size_t index : result.support) {
    const JoinHypothesis& h = join.hypotheses().at(index);
    for (const LoopClosure& loop : offered)
      if (loop.to == h.keyframe && loop.from == h.map_keyframe) {
        loops.push_back(loop);
        break;
      }
  }
  return loops;
}

}  // namespace

std::string MultiRobotOptions::validate() const {
  if (cross_candidates == 0) return "cross_candidates must be >= 1";
  if (search_threads == 0) return "search_threads must be >= 1";
  const std::string error = join.validate();
  return error.empty() ? "" : "join: " + error;
}

MultiRobotSlam::MultiRobotSlam(const ClassifierModel& model, std::size_t robots, const SlamOptions& slam,
                               const MultiRobotOptions& options, const SlamSession* saved_map)
    : options_(checked(options)), place_gate_(slam.place_gate), map_(slam.esdf, slam.gate_loops, slam.consensus) {
  if (robots == 0 || (saved_map && robots < 2))
    throw std::invalid_argument("multi-robot: at least one robot (besides a saved map)");
  for (std::size_t r = 0; r < robots; ++r) {
    robots_.push_back(std::make_unique<SlamPipeline>(model, slam));
    joins_.emplace_back(options_.join, [this](std::size_t a, std::size_t b) { return mapAllowance(a, b); }, kMapSigmas);
  }
  state_.resize(robots);
  state_[0].joined = true;  // robot 0's frame is the map's
  counters_.robots_joined = 1;
  if (!saved_map) return;
  // The saved map as robot 0: its store, chains and own graph (the odometry steps it saved give
  // its context), and the map's graph as it was saved.
  std::string error = saved_map->keyframes.empty() ? "it has no keyframe" : robots_[0]->restore(*saved_map, true);
  if (error.empty()) error = map_.restore(*saved_map);
  if (!error.empty()) throw std::invalid_argument("multi-robot: the saved map: " + error);
  const std::size_t n = saved_map->keyframes.size();
  saved_robots_ = saved_map->robots.empty() ? std::vector<std::uint32_t>(n, 0) : saved_map->robots;
  for (std::size_t k = 0; k < n; ++k) {
    state_[0].map_index.push_back(k);
    map_keyframes_.push_back({0, k});
  }
}

std::uint32_t MultiRobotSlam::sessionRobot(std::size_t robot, std::size_t keyframe) const {
  if (saved_robots_.empty()) return std::uint32_t(robot);
  if (robot == 0) return saved_robots_.at(keyframe);
  return *std::max_element(saved_robots_.begin(), saved_robots_.end()) + std::uint32_t(robot);
}

std::size_t MultiRobotSlam::mapIndex(std::size_t robot, std::size_t keyframe) const {
  const RobotState& state = state_.at(robot);
  if (!state.joined || keyframe >= state.map_index.size())
    throw std::out_of_range("multi-robot: keyframe " + std::to_string(keyframe) + " of robot " + std::to_string(robot) +
                            " is not in the map");
  return state.map_index[keyframe];
}

void MultiRobotSlam::refuseSavedMap(std::size_t robot) const {
  if (robot == 0 && hasSavedMap()) throw std::invalid_argument("multi-robot: robot 0 is the saved map: it takes no scans");
}

RobotStep MultiRobotSlam::addScan(std::size_t robot, const Scan& scan, std::size_t scan_index, const Pose2* wheel_odometry) {
  refuseSavedMap(robot);
  RobotStep step;
  step.slam = robots_.at(robot)->addScan(scan, scan_index, wheel_odometry);
  if (!step.slam.keyframe) return step;
  std::vector<LoopClosure> own_loops;
  for (const LoopClosure& loop : step.slam.loops.aligned)
    if (loop.accepted) own_loops.push_back(loop);
  keyframeAdded(robot, own_loops, step);
  return step;
}

RobotStep MultiRobotSlam::addKeyframe(std::size_t robot, Keyframe keyframe, const std::vector<double>& features,
                                      const OdometryStep& odometry) {
  refuseSavedMap(robot);
  RobotStep step;
  step.slam = robots_.at(robot)->addKeyframe(std::move(keyframe), features, odometry);
  keyframeAdded(robot, {}, step);
  return step;
}

LoopRecord MultiRobotSlam::addLoop(std::size_t robot, const LoopClosure& loop) {
  refuseSavedMap(robot);
  const LoopRecord record = robots_.at(robot)->addLoop(loop);  // a refused one is only recorded there
  RobotState& state = state_[robot];
  const std::size_t known = state.chain.size();
  if (!loop.accepted || loop.from >= known || loop.to >= known || loop.from == loop.to) return record;
  state.own_loops.push_back(loop);
  if (state.joined) applyToMap(robot, loop, robot);
  return record;
}

void MultiRobotSlam::keyframeAdded(std::size_t robot, const std::vector<LoopClosure>& own_loops, RobotStep& step) {
  const SlamPipeline& pipeline = *robots_[robot];
  RobotState& state = state_[robot];
  const std::size_t keyframe = step.slam.keyframe_index;
  // The robot's own odometry chain: what TrajectoryJoin places its keyframes by.
  if (state.chain.empty()) {
    state.chain.push_back(Pose2{});
  } else {
    // A step with no motion (a new chain after a time jump) leaves the keyframe where the
    // last one was: the join's drift allowance, not a NaN, absorbs it.
    const Pose2& motion = step.slam.odometry.motion;
    const bool finite = std::isfinite(motion.x) && std::isfinite(motion.y) && std::isfinite(motion.theta);
    state.chain.push_back(finite ? compose(state.chain.back(), motion) : state.chain.back());
    if (finite) state.path += std::hypot(motion.x, motion.y);
  }
  state.paths.push_back(state.path);
  state.steps.push_back(step.slam.odometry);
  state.own_loops.insert(state.own_loops.end(), own_loops.begin(), own_loops.end());

  if (state.joined) {
    enterKeyframe(robot, keyframe);
    for (const LoopClosure& loop : own_loops) applyToMap(robot, loop, robot);
  }
  const auto start = std::chrono::steady_clock::now();
  const LoopDetector& own = pipeline.detector();
  const Query query{own.features(keyframe), &own.prepared(keyframe), keyframe};
  const std::vector<std::pair<std::size_t, LoopClosure>> found = searchOthers(robot, query, step);
  if (state.joined) {
    for (const auto& [other, loop] : found) {
      const LoopRecord record = applyToMap(other, loop, robot);
      step.cross_applied += record.applied;
      if (!record.applied && record.refusal == LoopRefusal::kBackEndGate) ++counters_.cross_refused_by_gate;
    }
    searchUnjoined(robot, query, step);
  } else {
    std::vector<JoinHypothesis> hypotheses;
    for (const auto& [other, loop] : found) {
      LoopClosure in_map = loop;
      in_map.from = mapIndex(other, loop.from);  // kept by map index: what the join's hypotheses name
      hypotheses.push_back(joinHypothesis(robot, in_map));
    }
    step.join = joins_[robot].offer(hypotheses);
    if (step.join.joined) {
      step.joined_now = true;
      step.joined_robots.push_back(robot);
      joinRobot(robot, step.join.map_from_trajectory, step.join.newest.map_keyframe, loopsOfJoin(robot, step.join), step);
    } else {
      searchPeers(robot, query, step);
    }
  }
  counters_.cross_aligned += step.cross_aligned;
  counters_.cross_not_aligned += step.cross_not_aligned;
  counters_.cross_validated += step.cross_validated;
  counters_.cross_refused_by_context += step.cross_refused_by_context;
  counters_.seconds_search += secondsSince(start);
}

std::vector<LoopClosure> MultiRobotSlam::validatedLoops(const Query& query, std::size_t other, const CandidateCheck& check,
                                                       RobotStep& step) const {
  const LoopDetectionResult result = robots_[other]->detector().detectScan(
      query.features, *query.scan, query.keyframe, options_.cross_candidates, 0.0, options_.search_threads, check);
  step.cross_aligned += result.aligned.size();
  step.cross_not_aligned += result.not_aligned.size();
  std::vector<LoopClosure> loops;
  for (const LoopClosure& loop : result.aligned)
    if (loop.accepted) loops.push_back(loop);
  step.cross_validated += loops.size();
  return loops;
}

bool MultiRobotSlam::contextHolds(std::size_t from_robot, LoopClosure& loop, std::size_t to_robot, RobotStep& step) const {
  // Each end's context from its own robot's odometry chain (a loop between robots is checked
  // against both, as a loop within one run is: a corridor a door along fits worse).
  const LoopDetector& store = robots_[from_robot]->detector();
  if (!store.options().context.enabled) return true;
  store.checkContextWith(loop, store.size(), contextOf(from_robot), robots_[to_robot]->detector(), contextOf(to_robot));
  if (loop.accepted) return true;
  ++step.cross_refused_by_context;
  return false;
}

std::vector<std::pair<std::size_t, LoopClosure>> MultiRobotSlam::searchOthers(std::size_t robot, const Query& query,
                                                                               RobotStep& step) {
  std::vector<std::pair<std::size_t, LoopClosure>> found;
  for (std::size_t other = 0; other < robots_.size(); ++other) {
    if (other == robot || !state_[other].joined || robots_[other]->detector().size() == 0) continue;
    // A robot already in the map asks the map's place gate first, as mapping does: the map's
    // marginals say whether the two keyframes can be at one place (one not yet joined has no
    // relative prior to ask). Every keyframe of a joined robot is in the map.
    CandidateCheck place_gate;
    if (state_[robot].joined && place_gate_.enabled) {
      place_gate = [this, robot, other](std::size_t from, std::size_t to) {
        return placeGateVerdict(place_gate_, map_.placeChi2(mapIndex(other, from), mapIndex(robot, to), place_gate_.radius));
      };
    }
    for (LoopClosure& loop : validatedLoops(query, other, place_gate, step))
      if (contextHolds(other, loop, robot, step)) found.emplace_back(other, loop);
  }
  return found;
}

KeyframeContext MultiRobotSlam::contextOf(std::size_t robot) const {
  const SlamFrontEnd& front = robots_[robot]->frontEnd();
  return [&front](std::size_t index, std::size_t before, double distance, double spacing) {
    return front.context(index, before, distance, spacing);
  };
}

JoinHypothesis MultiRobotSlam::joinHypothesis(std::size_t robot, const LoopClosure& loop) {
  RobotState& state = state_[robot];
  JoinHypothesis h;
  h.keyframe = loop.to;
  h.path = state.paths.at(loop.to);
  h.trajectory_pose = state.chain.at(loop.to);
  h.map_keyframe = loop.from;
  h.map_pose = compose(map_.poses()[loop.from], loop.pose);
  h.covariance = loop.covariance;
  h.view_width = robots_[robot]->detector().prepared(loop.to).view.width();
  if (Esdf* esdf = map_.esdf(); esdf && loop.from < esdf->size()) {
    const Eigen::Matrix3d c = esdf->marginalCovariance(loop.from);
    h.map_std = std::sqrt(std::max(0.0, c(0, 0) + c(1, 1)));  // at least the largest standard deviation
  }
  state.joining_loops.push_back(loop);
  return h;
}

MapAllowance MultiRobotSlam::mapAllowance(std::size_t map_a, std::size_t map_b) {
  MapAllowance allowance;
  Esdf* esdf = map_.esdf();
  if (!esdf || map_a >= esdf->size() || map_b >= esdf->size()) return allowance;
  Pose2 relative;
  Eigen::Matrix3d covariance;
  esdf->relativePose(map_a, map_b, &relative, &covariance);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> translation(covariance.topLeftCorner<2, 2>());
  allowance.translation = kMapSigmas * std::sqrt(std::max(0.0, translation.eigenvalues().maxCoeff()));
  allowance.rotation = kMapSigmas * std::sqrt(std::max(0.0, covariance(2, 2)));
  if (!std::isfinite(allowance.translation) || !std::isfinite(allowance.rotation)) return {};
  return allowance;
}

void MultiRobotSlam::searchUnjoined(std::size_t robot, const Query& query, RobotStep& step) {
  const LoopDetector& own = robots_[robot]->detector();
  for (std::size_t other = 0; other < robots_.size(); ++other) {
    if (other == robot || state_[other].joined || robots_[other]->detector().size() == 0) continue;
    const LoopDetector& store = robots_[other]->detector();
    std::vector<JoinHypothesis> hypotheses;
    for (const LoopClosure& found : validatedLoops(query, other, {}, step)) {
      // The same pair the other way round: the other robot's keyframe seen from this one's,
      // as its own search would have found it (a loop, its covariance, in the join's terms).
      LoopClosure loop = own.verifyScan(query.keyframe, store.prepared(found.from), found.from, found.score);
      if (!loop.accepted || !contextHolds(robot, loop, other, step)) continue;
      loop.from = mapIndex(robot, query.keyframe);
      hypotheses.push_back(joinHypothesis(other, loop));
    }
    if (hypotheses.empty()) continue;
    const TrajectoryJoinResult join = joins_[other].offer(hypotheses);
    if (!join.joined) continue;
    step.joined_robots.push_back(other);
    joinRobot(other, join.map_from_trajectory, join.newest.map_keyframe, loopsOfJoin(other, join), step);
  }
}

void MultiRobotSlam::searchPeers(std::size_t robot, const Query& query, RobotStep& step) {
  auto linked = [this](std::size_t a, std::size_t b) {
    for (const Link& link : links_)
      if ((link.a == a && link.b == b) || (link.a == b && link.b == a)) return true;
    return false;
  };
  for (std::size_t other = 0; other < robots_.size(); ++other) {
    if (other == robot || state_[other].joined || robots_[other]->detector().size() == 0 || linked(robot, other)) continue;
    const std::pair<std::size_t, std::size_t> pair{robot, other};
    std::vector<JoinHypothesis> hypotheses;
    for (LoopClosure& loop : validatedLoops(query, other, {}, step)) {
      if (!contextHolds(other, loop, robot, step)) continue;
      // Where the other robot's odometry chain puts this keyframe: a place in its own frame.
      JoinHypothesis h;
      h.keyframe = query.keyframe;
      h.path = state_[robot].path;
      h.trajectory_pose = state_[robot].chain[query.keyframe];
      h.map_keyframe = loop.from;
      h.map_pose = compose(state_[other].chain.at(loop.from), loop.pose);
      h.covariance = loop.covariance;
      h.view_width = query.scan->view.width();
      hypotheses.push_back(h);
      peer_loops_[pair].push_back(loop);
    }
    if (hypotheses.empty()) continue;
    TrajectoryJoin& join = peer_joins_.try_emplace(pair, options_.join).first->second;
    const TrajectoryJoinResult result = join.offer(hypotheses);
    if (!result.joined) continue;
    Link link{other, robot, {}};
    for (const LoopClosure& loop : supportingLoops(join, result, peer_loops_[pair])) link.loops.push_back({other, robot, loop});
    links_.push_back(std::move(link));
    ++counters_.robot_links;
    peer_joins_.erase(pair);
    peer_loops_.erase(pair);
  }
}

std::vector<MultiRobotSlam::RobotLoop> MultiRobotSlam::loopsOfJoin(std::size_t robot, const TrajectoryJoinResult& join) const {
  std::vector<RobotLoop> loops;
  for (LoopClosure loop : supportingLoops(joins_[robot], join, state_[robot].joining_loops)) {
    const RobotKeyframe other = map_keyframes_.at(loop.from);  // the joining loops name map keyframes
    loop.from = other.keyframe;
    loops.push_back({other.robot, robot, loop});
  }
  return loops;
}

void MultiRobotSlam::joinLinked(std::size_t robot, RobotStep& step) {
  for (std::size_t i = 0; i < links_.size(); ++i) {
    const Link& link = links_[i];  // joinRobot makes no links: the reference stays valid
    if ((link.a != robot && link.b != robot) || link.loops.empty()) continue;
    const std::size_t other = link.a == robot ? link.b : link.a;
    if (state_[other].joined) continue;
    // The newest loop of the link places the other robot's keyframe by this one's map pose.
    const RobotLoop& newest = link.loops.back();
    const bool from_joined = newest.from_robot == robot;
    const std::size_t anchor = mapIndex(robot, from_joined ? newest.loop.from : newest.loop.to);
    const std::size_t its_keyframe = from_joined ? newest.loop.to : newest.loop.from;
    const Pose2 its_pose = from_joined ? compose(map_.poses()[anchor], newest.loop.pose)
                                       : compose(map_.poses()[anchor], inverse(newest.loop.pose));
    step.joined_robots.push_back(other);
    joinRobot(other, compose(its_pose, inverse(state_[other].chain.at(its_keyframe))), anchor, link.loops, step);
  }
}

void MultiRobotSlam::enterKeyframe(std::size_t robot, std::size_t keyframe) {
  RobotState& state = state_[robot];
  const Keyframe& kf = robots_[robot]->keyframes().at(keyframe);
  if (keyframe == 0) {
    // Only robot 0's first keyframe starts the map (a joining robot's first is linked in joinRobot).
    map_.addKeyframe(kf, Pose2{}, Eigen::Matrix3d::Identity());
  } else {
    const OdometryStep& odometry = state.steps[keyframe];
    map_.addKeyframeFrom(state.map_index.at(keyframe - 1), kf, odometry.motion, odometry.covariance);
  }
  state.map_index.push_back(map_keyframes_.size());
  map_keyframes_.push_back({robot, keyframe});
}

LoopRecord MultiRobotSlam::applyToMap(std::size_t from_robot, const LoopClosure& loop, std::size_t to_robot, bool joining) {
  LoopClosure in_map = loop;
  in_map.from = mapIndex(from_robot, loop.from);
  in_map.to = mapIndex(to_robot, loop.to);
  const LoopRecord record = map_.addLoop(in_map);
  if (from_robot != to_robot) {
    cross_loops_.push_back({{from_robot, loop.from}, {to_robot, loop.to}, record, joining});
    counters_.cross_robot_loops += record.applied;
  }
  return record;
}

void MultiRobotSlam::joinRobot(std::size_t robot, const Pose2& map_from_trajectory, std::size_t anchor,
                               const std::vector<RobotLoop>& loops, RobotStep& step) {
  RobotState& state = state_[robot];
  // The first keyframe: where the join's frame puts it, loosely linked to the map keyframe of
  // the newest joining loop (the loops below place it; the link only gives it a mean).
  const Pose2 first_in_map = compose(map_from_trajectory, state.chain[0]);
  map_.addKeyframeFrom(anchor, robots_[robot]->keyframes().at(0), between(map_.poses()[anchor], first_in_map),
                       looseLinkCovariance());
  state.joined = true;
  state.joined_at_path = state.path;
  state.map_index.push_back(map_keyframes_.size());
  map_keyframes_.push_back({robot, 0});
  for (std::size_t k = 1; k < state.chain.size(); ++k) enterKeyframe(robot, k);
  for (const LoopClosure& loop : state.own_loops) applyToMap(robot, loop, robot);
  // The loops that joined it (one per supporting keyframe), once both ends are in the map.
  for (const RobotLoop& joining : loops) {
    if (!joined(joining.from_robot) || !joined(joining.to_robot)) continue;
    step.cross_applied += applyToMap(joining.from_robot, joining.loop, joining.to_robot, true).applied;
  }
  state.joining_loops.clear();
  joins_[robot].clear();
  for (auto it = peer_joins_.begin(); it != peer_joins_.end();)  // its pairs now search the map instead
    it = it->first.first == robot || it->first.second == robot ? peer_joins_.erase(it) : std::next(it);
  for (auto it = peer_loops_.begin(); it != peer_loops_.end();)
    it = it->first.first == robot || it->first.second == robot ? peer_loops_.erase(it) : std::next(it);
  ++counters_.robots_joined;
  joinLinked(robot, step);
}

SlamSession MultiRobotSlam::session() const {
  std::vector<std::vector<double>> features;
  for (const RobotKeyframe& k : map_keyframes_) features.push_back(robots_[k.robot]->detector().features(k.keyframe));
  SlamSession session = sessionOf(map_, features);
  for (const RobotKeyframe& k : map_keyframes_) session.robots.push_back(sessionRobot(k.robot, k.keyframe));
  return session;
}

std::vector<ScanPose> MultiRobotSlam::scanPoses(std::size_t robot) const {
  std::vector<ScanPose> scans = robots_.at(robot)->scanPoses();
  const RobotState& state = state_[robot];
  if (!state.joined) return scans;
  const std::vector<Pose2>& own = robots_[robot]->poses();
  const std::vector<Pose2>& map = map_.poses();
  for (ScanPose& s : scans) {
    if (s.keyframe >= state.map_index.size()) continue;
    // The scan's offset from its keyframe in the robot's own map, carried by the keyframe's map pose.
    s.pose = compose(map[state.map_index[s.keyframe]], between(own[s.keyframe], s.pose));
  }
  return scans;
}

}  // namespace llc
