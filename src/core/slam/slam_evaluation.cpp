#include "laser_loop_closure/core/slam/slam_evaluation.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>

namespace llc {

namespace {

bool trueRevisit(const Pose2& older, const Pose2& newer, bool full_circle, const LoopTruthOptions& options) {
  const Pose2 d = between(older, newer);
  return std::hypot(d.x, d.y) < options.positive_distance && (full_circle || std::abs(d.theta) < options.positive_heading);
}

bool wrongLoop(const std::vector<Pose2>& truth, const LoopClosure& loop, const LoopTruthOptions& options) {
  const Pose2 error = between(between(truth[loop.from], truth[loop.to]), loop.pose);
  return std::hypot(error.x, error.y) > options.wrong_translation || std::abs(error.theta) > options.wrong_rotation;
}

/// Keyframes (at least min_keyframe_gap in) with an older keyframe of the same place.
std::vector<bool> revisitKeyframes(const std::vector<Pose2>& truth, const std::vector<bool>& full_circle,
                                   const LoopTruthOptions& options) {
  std::vector<bool> revisit(truth.size(), false);
  const std::size_t gap = options.min_keyframe_gap;
  for (std::size_t k = gap; k < truth.size(); ++k) {
    const bool full = k < full_circle.size() && full_circle[k];
    for (std::size_t j = 0; j + gap <= k && !revisit[k]; ++j) revisit[k] = trueRevisit(truth[j], truth[k], full, options);
  }
  return revisit;
}

}  // namespace

std::size_t countTrueRevisitPairs(const std::vector<Pose2>& truth, const std::vector<bool>& full_circle,
                                  const std::vector<LoopClosure>& pairs, const LoopTruthOptions& options) {
  std::size_t count = 0;
  for (const LoopClosure& pair : pairs) {
    if (pair.from >= truth.size() || pair.to >= truth.size()) continue;
    const bool full = pair.to < full_circle.size() && full_circle[pair.to];
    count += trueRevisit(truth[pair.from], truth[pair.to], full, options);
  }
  return count;
}

LoopTruthCheck checkLoopsAgainstTruth(const std::vector<Pose2>& truth, const std::vector<bool>& full_circle,
                                      const std::vector<LoopRecord>& loops, const LoopTruthOptions& options) {
  LoopTruthCheck check;
  std::vector<bool> closed(truth.size(), false);
  for (const LoopRecord& record : loops) {
    if (!record.applied || record.loop.from >= truth.size() || record.loop.to >= truth.size()) continue;
    const Pose2 error = between(between(truth[record.loop.from], truth[record.loop.to]), record.loop.pose);
    const Eigen::Vector3d e(error.x, error.y, error.theta);
    check.loop_nees += e.dot(record.loop.covariance.ldlt().solve(e));
    ++check.applied;
    if (wrongLoop(truth, record.loop, options))
      ++check.wrong_loops;
    else
      closed[record.loop.to] = true;
  }
  if (check.applied > 0) check.loop_nees /= double(check.applied);
  const std::vector<bool> revisit = revisitKeyframes(truth, full_circle, options);
  for (std::size_t k = 0; k < truth.size(); ++k) {
    check.true_loop_keyframes += revisit[k];
    check.closed += revisit[k] && closed[k];
  }
  return check;
}

RevisitFates revisitFates(const std::vector<Pose2>& truth, const std::vector<bool>& full_circle,
                          const std::vector<LoopRecord>& loops, const std::vector<LoopClosure>& not_aligned,
                          const LoopTruthOptions& options) {
  // Stage reached per keyframe by its furthest true candidate: 0 none, 1 skipped before
  // alignment, 2 refused by alignment, 3 refused by the gate, 4 applied wrong, 5 closed.
  std::vector<int> stage(truth.size(), 0);
  const auto reach = [&](const LoopClosure& loop, int reached) {
    if (loop.from >= truth.size() || loop.to >= truth.size()) return;
    const bool full = loop.to < full_circle.size() && full_circle[loop.to];
    if (trueRevisit(truth[loop.from], truth[loop.to], full, options)) stage[loop.to] = std::max(stage[loop.to], reached);
  };
  for (const LoopClosure& loop : not_aligned) reach(loop, 1);
  for (const LoopRecord& record : loops) {
    if (record.applied && record.loop.from < truth.size() && record.loop.to < truth.size())
      reach(record.loop, wrongLoop(truth, record.loop, options) ? 4 : 5);
    else
      reach(record.loop, record.loop.accepted ? 3 : 2);
  }
  // A right loop to a place the labelling does not call a revisit (just beyond its radius)
  // still closes the keyframe, as checkLoopsAgainstTruth counts it.
  std::vector<bool> closed(truth.size(), false);
  for (const LoopRecord& record : loops)
    if (record.applied && record.loop.from < truth.size() && record.loop.to < truth.size() &&
        !wrongLoop(truth, record.loop, options))
      closed[record.loop.to] = true;
  RevisitFates fates;
  const std::vector<bool> revisit = revisitKeyframes(truth, full_circle, options);
  for (std::size_t k = 0; k < truth.size(); ++k) {
    if (!revisit[k] || closed[k]) continue;
    ++fates.open;
    switch (stage[k]) {
      case 0: ++fates.no_true_candidate; break;
      case 1: ++fates.place_gate; break;
      case 2: ++fates.alignment; break;
      case 3: ++fates.back_end_gate; break;
      default: ++fates.wrong_pose; break;
    }
  }
  return fates;
}

}  // namespace llc
