#include "laser_loop_closure/core/slam_evaluation.hpp"

#include <Eigen/Cholesky>
#include <cmath>

namespace llc {

namespace {

bool trueRevisit(const Pose2& older, const Pose2& newer, bool full_circle, const LoopTruthOptions& options) {
  const Pose2 d = between(older, newer);
  return std::hypot(d.x, d.y) < options.positive_distance && (full_circle || std::abs(d.theta) < options.positive_heading);
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
    if (std::hypot(error.x, error.y) > options.wrong_translation || std::abs(error.theta) > options.wrong_rotation)
      ++check.wrong_loops;
    else
      closed[record.loop.to] = true;
  }
  if (check.applied > 0) check.loop_nees /= double(check.applied);
  const std::size_t gap = options.min_keyframe_gap;
  for (std::size_t k = gap; k < truth.size(); ++k) {
    const bool full = k < full_circle.size() && full_circle[k];
    bool revisit = false;
    for (std::size_t j = 0; j + gap <= k && !revisit; ++j) revisit = trueRevisit(truth[j], truth[k], full, options);
    check.true_loop_keyframes += revisit;
    check.closed += revisit && closed[k];
  }
  return check;
}

}  // namespace llc
