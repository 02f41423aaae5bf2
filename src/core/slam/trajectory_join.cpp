#include "laser_loop_closure/core/slam/trajectory_join.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace llc {

std::string TrajectoryJoinOptions::validate() const {
  if (min_keyframes < 2) return "min_keyframes must be >= 2 (one loop alone is a guess)";
  if (!(min_spread >= 0.0) || !std::isfinite(min_spread)) return "min_spread must be >= 0 m";
  if (!(min_new_view >= 0.0 && min_new_view <= M_PI)) return "min_new_view must be in [0, pi] rad";
  if (!(max_translation > 0.0) || !std::isfinite(max_translation)) return "max_translation must be > 0 m";
  if (!(max_rotation > 0.0) || !std::isfinite(max_rotation)) return "max_rotation must be > 0 rad";
  if (!(drift_per_metre >= 0.0) || !std::isfinite(drift_per_metre)) return "drift_per_metre must be >= 0";
  if (!(drift_rad_per_metre >= 0.0) || !std::isfinite(drift_rad_per_metre)) return "drift_rad_per_metre must be >= 0";
  if (!(window > min_spread) || !std::isfinite(window)) return "window must be finite and > min_spread";
  return "";
}

namespace {

/// rad of view the keyframes see together beyond what one of them sees: their largest heading
/// difference, up to what the widest field of view leaves unseen.
double newViewOf(const std::vector<JoinHypothesis>& kept, const std::vector<std::size_t>& story) {
  double turn = 0.0, widest = 0.0;
  for (std::size_t i : story) {
    widest = std::max(widest, kept[i].view_width);
    for (std::size_t j : story)
      turn = std::max(turn, std::abs(normalizeAngle(kept[i].trajectory_pose.theta - kept[j].trajectory_pose.theta)));
  }
  return std::min(turn, std::max(0.0, 2.0 * M_PI - widest));
}

}  // namespace

TrajectoryJoin::TrajectoryJoin(const TrajectoryJoinOptions& options, MapAllowanceOf map_allowance, double map_sigmas)
    : options_(options), map_allowance_(std::move(map_allowance)), map_sigmas_(map_sigmas) {
  const std::string error = options_.validate();
  if (!error.empty()) throw std::invalid_argument("trajectory join options: " + error);
}

bool TrajectoryJoin::agree(const JoinHypothesis& a, const JoinHypothesis& b) const {
  const double path = std::abs(a.path - b.path);
  const Pose2 placed = compose(a.mapFromTrajectory(), b.trajectory_pose);
  const Pose2 miss = between(b.map_pose, placed);
  const double distance = std::hypot(miss.x, miss.y), turn = std::abs(normalizeAngle(miss.theta));
  const double translation = options_.max_translation + options_.drift_per_metre * path;
  const double rotation = options_.max_rotation + options_.drift_rad_per_metre * path;
  if (distance <= translation && turn <= rotation) return true;
  // The map's own error between the two keyframes may explain the miss: asked only where its
  // bound could (in a map whose keyframes are known to centimetres, almost never).
  if (!map_allowance_ || a.map_keyframe == b.map_keyframe || distance > translation + map_sigmas_ * (a.map_std + b.map_std))
    return false;
  const auto key = std::minmax(a.map_keyframe, b.map_keyframe);
  auto found = allowances_.find(key);
  if (found == allowances_.end()) found = allowances_.emplace(key, map_allowance_(key.first, key.second)).first;
  return distance <= translation + found->second.translation && turn <= rotation + found->second.rotation;
}

std::vector<std::size_t> TrajectoryJoin::storyOf(std::size_t index) const {
  std::vector<std::size_t> agreeing;
  for (std::size_t j = 0; j < kept_.size(); ++j)
    if (j == index || agree(kept_[index], kept_[j])) agreeing.push_back(j);
  const double path = kept_[index].path;
  std::stable_sort(agreeing.begin(), agreeing.end(), [&](std::size_t a, std::size_t b) {
    return std::abs(kept_[a].path - path) < std::abs(kept_[b].path - path);
  });
  std::vector<std::size_t> story;  // one loop per keyframe, the anchor's own keyframe by the anchor
  for (std::size_t j : agreeing) {
    const bool seen = std::any_of(story.begin(), story.end(), [&](std::size_t s) { return kept_[s].keyframe == kept_[j].keyframe; });
    if (!seen) story.push_back(j);
  }
  return story;
}

TrajectoryJoinResult TrajectoryJoin::offer(const std::vector<JoinHypothesis>& loops) {
  allowances_.clear();  // the map may have moved since the last offer
  for (const JoinHypothesis& loop : loops)
    if (isFinite(loop.trajectory_pose) && isFinite(loop.map_pose) && std::isfinite(loop.path)) kept_.push_back(loop);
  TrajectoryJoinResult result;
  if (kept_.empty()) {
    result.why_not = "no loop to the map yet";
    return result;
  }
  double newest = kept_.front().path;
  for (const JoinHypothesis& loop : kept_) newest = std::max(newest, loop.path);
  kept_.erase(std::remove_if(kept_.begin(), kept_.end(), [&](const JoinHypothesis& loop) { return loop.path < newest - options_.window; }),
              kept_.end());
  // The story with the most keyframes (the newer anchor on ties: less drift to the robot now).
  std::size_t best = 0;
  std::vector<std::size_t> best_story;
  for (std::size_t i = 0; i < kept_.size(); ++i) {
    std::vector<std::size_t> story = storyOf(i);
    if (story.size() > best_story.size() || (story.size() == best_story.size() && kept_[i].path >= kept_[best].path))
      best = i, best_story = std::move(story);
  }
  // Stories that contradict the winner, each told once (an anchor agreeing with none told yet).
  std::vector<std::pair<std::size_t, std::size_t>> rivals;  // (keyframes, anchor)
  for (std::size_t i = 0; i < kept_.size(); ++i)
    if (!agree(kept_[best], kept_[i])) rivals.emplace_back(storyOf(i).size(), i);
  std::stable_sort(rivals.begin(), rivals.end(), [&](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : kept_[a.second].path > kept_[b.second].path;
  });
  const std::size_t rival = rivals.empty() ? 0 : rivals.front().first;
  std::vector<std::size_t> told;
  for (const auto& [size, anchor] : rivals) {
    if (told.size() == 3) break;
    const bool same = std::any_of(told.begin(), told.end(), [&](std::size_t t) { return agree(kept_[t], kept_[anchor]); });
    if (!same) told.push_back(anchor);
  }
  double first = kept_[best].path, last = first;
  std::size_t newest_loop = best;
  for (std::size_t j : best_story) {
    first = std::min(first, kept_[j].path), last = std::max(last, kept_[j].path);
    if (kept_[j].path > kept_[newest_loop].path) newest_loop = j;
  }
  result.keyframes = best_story.size();
  result.rival_keyframes = rival;
  if (best_story.size() < options_.min_keyframes) {
    result.why_not = std::to_string(best_story.size()) + " keyframes agree, " + std::to_string(options_.min_keyframes) + " needed";
  } else if (last - first < options_.min_spread &&
             !(options_.min_new_view > 0.0 && newViewOf(kept_, best_story) >= options_.min_new_view)) {
    result.why_not = "the keyframes that agree span " + std::to_string(last - first) + " m of path and see " +
                     std::to_string(newViewOf(kept_, best_story)) + " rad more than one of them, " +
                     std::to_string(options_.min_spread) + " m or " + std::to_string(options_.min_new_view) + " rad needed";
  } else if (best_story.size() < rival + options_.min_lead) {
    result.why_not = std::to_string(best_story.size()) + " keyframes agree, but " + std::to_string(rival) +
                     " agree on another place";
  } else if (rival >= options_.min_keyframes) {
    // Two places that each earned a fix: the map is ambiguous here (a corridor of like doors);
    // a longer story is no proof, and the join waits until the other one leaves its window.
    result.why_not = std::to_string(best_story.size()) + " keyframes agree, but " + std::to_string(rival) +
                     " agree on another place, enough for a fix of its own";
  } else {
    result.joined = true;
    result.map_from_trajectory = kept_[newest_loop].mapFromTrajectory();
    result.newest = kept_[newest_loop];
    for (std::size_t t : told) result.rival_frames.push_back(kept_[t].mapFromTrajectory());
    result.support = std::move(best_story);
  }
  return result;
}

}  // namespace llc
