#include "laser_loop_closure/core/slam/loop_consensus.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "laser_loop_closure/core/geometry/se2_jacobians.hpp"

namespace llc {

std::string LoopConsensusOptions::validate() const {
  if (min_loops < 2) return "min_loops must be >= 2 (one loop alone is what the gate judges)";
  if (max_keyframe_span < 1) return "max_keyframe_span must be >= 1";
  if (!(pair_chi2 > 0.0) || !std::isfinite(pair_chi2)) return "pair_chi2 must be finite and > 0";
  if (max_held < min_loops - 1) return "max_held must be >= min_loops - 1";
  return "";
}

double loopPairChi2(const LoopClosure& first, const LoopClosure& second, const Pose2& older_ends,
                    const Eigen::Matrix3d& older_ends_covariance, const Pose2& newer_ends,
                    const Eigen::Matrix3d& newer_ends_covariance) {
  // second.pose predicted: second.from -> first.from -> (first's loop) first.to -> second.to.
  const Pose2 via_first = compose(older_ends, first.pose);
  const Pose2 predicted = compose(via_first, newer_ends);
  Eigen::Matrix3d j_older, j_first, j_via, j_newer;
  composeJacobians(older_ends, first.pose, &j_older, &j_first);
  composeJacobians(via_first, newer_ends, &j_via, &j_newer);
  const Eigen::Matrix3d via_covariance =
      j_older * older_ends_covariance * j_older.transpose() + j_first * first.covariance * j_first.transpose();
  const Eigen::Matrix3d innovation_covariance = j_via * via_covariance * j_via.transpose() +
                                                j_newer * newer_ends_covariance * j_newer.transpose() + second.covariance;
  const Eigen::Vector3d error = poseDifference(predicted, second.pose);
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(innovation_covariance);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return std::numeric_limits<double>::infinity();
  const double chi2 = error.dot(ldlt.solve(error));
  return std::isfinite(chi2) ? chi2 : std::numeric_limits<double>::infinity();
}

LoopConsensus::LoopConsensus(const LoopConsensusOptions& options) : options_(options) {
  const std::string error = options_.validate();
  if (!error.empty()) throw std::invalid_argument("consensus options: " + error);
}

void LoopConsensus::hold(const LoopClosure& loop, std::size_t record) {
  if (!options_.enabled) return;
  // Loops whose newer end is too far behind this one can never be compared again.
  held_.erase(std::remove_if(held_.begin(), held_.end(),
                             [&](const Held& h) { return h.loop.to + options_.max_keyframe_span < loop.to; }),
              held_.end());
  held_.push_back({loop, record});
  if (held_.size() > options_.max_held) held_.erase(held_.begin());
}

bool LoopConsensus::near(const LoopClosure& a, const LoopClosure& b) const {
  auto gap = [](std::size_t x, std::size_t y) { return x > y ? x - y : y - x; };
  return a.to != b.to && a.from != b.from && gap(a.from, b.from) <= options_.max_keyframe_span && gap(a.to, b.to) <= options_.max_keyframe_span;
}

bool LoopConsensus::consistent(const LoopClosure& a, const LoopClosure& b, Esdf& esdf) const {
  Pose2 older, newer;
  Eigen::Matrix3d older_covariance = Eigen::Matrix3d::Zero(), newer_covariance = Eigen::Matrix3d::Zero();
  try {
    if (b.from != a.from) esdf.relativePose(b.from, a.from, &older, &older_covariance);
    if (a.to != b.to) esdf.relativePose(a.to, b.to, &newer, &newer_covariance);
  } catch (const std::exception&) {
    return false;  // a keyframe the filter does not have (cannot happen for loops it holds)
  }
  return loopPairChi2(a, b, older, older_covariance, newer, newer_covariance) <= options_.pair_chi2;
}

std::vector<std::size_t> LoopConsensus::agree(const LoopClosure& loop, Esdf& esdf) {
  if (!options_.enabled) return {};
  std::vector<std::size_t> candidates;  // indices into held_ that agree with the new loop
  for (std::size_t k = 0; k < held_.size(); ++k)
    if (near(held_[k].loop, loop) && consistent(held_[k].loop, loop, esdf)) candidates.push_back(k);
  if (candidates.size() + 1 < options_.min_loops) return {};
  // Greedily, newest first: each one kept agrees with every one kept before it.
  std::vector<std::size_t> group;
  for (auto it = candidates.rbegin(); it != candidates.rend(); ++it) {
    bool fits = true;
    for (const std::size_t g : group)
      if (!near(held_[g].loop, held_[*it].loop) || !consistent(held_[g].loop, held_[*it].loop, esdf)) {
        fits = false;
        break;
      }
    if (fits) group.push_back(*it);
  }
  if (group.size() + 1 < options_.min_loops) return {};
  std::sort(group.begin(), group.end());
  std::vector<std::size_t> records;
  for (const std::size_t g : group) records.push_back(held_[g].record);
  for (auto it = group.rbegin(); it != group.rend(); ++it) held_.erase(held_.begin() + std::ptrdiff_t(*it));
  return records;
}

}  // namespace llc
