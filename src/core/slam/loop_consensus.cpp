#include "laser_loop_closure/core/slam/loop_consensus.hpp"

#include <cmath>
#include <stdexcept>

namespace llc {

std::string LoopConsensusOptions::validate() const {
  if (min_loops == 1) return "min_loops must be 0 (off) or >= 2: one loop alone is the gate's to judge";
  if (!(max_chi2 > 0.0) || !std::isfinite(max_chi2)) return "max_chi2 must be finite and > 0";
  if (!(max_translation > 0.0) || !std::isfinite(max_translation)) return "max_translation must be finite and > 0";
  if (!(max_rotation > 0.0) || !(max_rotation < M_PI)) return "max_rotation must be in (0, pi)";
  if (max_kept < min_loops) return "max_kept must be >= min_loops";
  return "";
}

LoopConsensus::LoopConsensus(const LoopConsensusOptions& options) : options_(options) {
  const std::string error = options_.validate();
  if (!error.empty()) throw std::invalid_argument("consensus options: " + error);
}

bool LoopConsensus::agree(const LoopClosure& a, const LoopClosure& b, const std::vector<Pose2>& poses) const {
  const std::size_t n = poses.size();
  if (a.from >= n || a.to >= n || b.from >= n || b.to >= n) return false;
  auto apart = [](std::size_t i, std::size_t j) { return i > j ? i - j : j - i; };
  if (apart(a.from, b.from) > options_.max_keyframes_apart || apart(a.to, b.to) > options_.max_keyframes_apart) return false;
  // The map is trusted only over the short stretches between the two loops' ends (it is the
  // long way round between a loop's own ends that the gate found wrong).
  const Pose2 older = between(poses[a.from], poses[b.from]);
  const Pose2 newer = between(poses[a.to], poses[b.to]);
  const Pose2 miss = between(compose(older, b.pose), compose(a.pose, newer));
  return std::hypot(miss.x, miss.y) <= options_.max_translation && std::abs(miss.theta) <= options_.max_rotation;
}

bool LoopConsensus::mayWait(const LoopClosure& loop, double chi2) const {
  return options_.min_loops > 0 && chi2 <= options_.max_chi2 && isFinite(loop.pose);
}

bool LoopConsensus::keep(std::size_t id, const LoopClosure& loop, double chi2) {
  if (!mayWait(loop, chi2)) return false;
  if (kept_.size() >= options_.max_kept) kept_.erase(kept_.begin());
  kept_.push_back({id, loop});
  return true;
}

LoopConsensusResult LoopConsensus::offer(std::size_t id, const LoopClosure& loop, double chi2, const std::vector<Pose2>& poses) {
  LoopConsensusResult result;
  if (!mayWait(loop, chi2)) return result;
  std::vector<std::size_t> agreeing;  // indices into kept_
  for (std::size_t k = 0; k < kept_.size(); ++k)
    if (agree(loop, kept_[k].loop, poses)) agreeing.push_back(k);
  if (agreeing.size() + 1 < options_.min_loops) {
    result.kept = keep(id, loop, chi2);
    return result;
  }
  std::vector<Kept> rest;
  std::size_t next = 0;
  for (std::size_t k = 0; k < kept_.size(); ++k) {
    if (next < agreeing.size() && agreeing[next] == k) {
      result.group.push_back(kept_[k].id);
      ++next;
    } else {
      rest.push_back(std::move(kept_[k]));
    }
  }
  result.group.push_back(id);
  kept_ = std::move(rest);
  return result;
}

}  // namespace llc
