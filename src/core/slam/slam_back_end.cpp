#include "laser_loop_closure/core/slam/slam_back_end.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include "laser_loop_closure/core/common/file_util.hpp"
#include "laser_loop_closure/core/slam/session_io.hpp"

namespace llc {
namespace {


/// Finite, symmetric within rounding and positive definite.
bool usableCovariance(const Eigen::Matrix3d& c) {
  if (!c.allFinite() || !c.isApprox(c.transpose(), 1e-9)) return false;
  Eigen::LLT<Eigen::Matrix3d> llt(c);
  return llt.info() == Eigen::Success;
}

/// Refused by the chi-square gate itself (not by the filter's limits after it): the loops a
/// consensus may apply later.
bool refusedByGate(const LoopRecord& record) { return !record.applied && record.refusal == LoopRefusal::kBackEndGate; }

LoopRefusal loopRefusalOf(EsdfRefusal refusal) {
  switch (refusal) {
    case EsdfRefusal::kNone: return LoopRefusal::kNone;
    case EsdfRefusal::kMalformed: return LoopRefusal::kBackEndMalformed;
    case EsdfRefusal::kGate: return LoopRefusal::kBackEndGate;
    case EsdfRefusal::kUnsolvable: return LoopRefusal::kBackEndUnsolvable;
  }
  return LoopRefusal::kOther;
}

const EsdfOptions& checked(const EsdfOptions& options) {
  const std::string error = options.validate();
  if (!error.empty()) throw std::invalid_argument("esdf options: " + error);
  return options;
}

}  // namespace

SlamBackEnd::SlamBackEnd(const EsdfOptions& options, bool gate_loops, const LoopConsensusOptions& consensus)
    : options_(checked(options)), gate_loops_(gate_loops), consensus_(consensus) {}

const std::vector<Pose2>& SlamBackEnd::poses() const {
  static const std::vector<Pose2> none;
  return esdf_ ? esdf_->mean() : none;
}

Pose2 SlamBackEnd::mapToOdom() const {
  if (keyframes_.empty() || !keyframes_.back().has_wheel_odometry) return Pose2{};
  return compose(esdf_->mean().back(), inverse(keyframes_.back().wheel_odometry));
}

Eigen::Matrix3d SlamBackEnd::latestCovariance() {
  if (!esdf_) return Eigen::Matrix3d::Zero();
  return esdf_->marginalCovariance(esdf_->size() - 1);
}

double SlamBackEnd::placeChi2(std::size_t from, std::size_t to, double radius) {
  if (!esdf_) throw std::out_of_range("placeChi2: no keyframe yet");
  const auto start = std::chrono::steady_clock::now();
  const double chi2 = esdf_->placeChi2(from, to, radius);
  counters_.seconds += secondsSince(start);
  return chi2;
}

std::vector<NearbyKeyframe> SlamBackEnd::nearbyKeyframes(std::size_t index, std::size_t before, double max_distance,
                                                      double max_std, std::size_t count) {
  if (!esdf_ || index >= esdf_->size()) throw std::out_of_range("nearbyKeyframes: no keyframe " + std::to_string(index));
  const auto start = std::chrono::steady_clock::now();
  const std::vector<Pose2>& mean = esdf_->mean();
  std::vector<std::pair<double, std::size_t>> near;
  for (std::size_t k = 0; k < std::min(before, mean.size()); ++k) {
    const double distance = std::hypot(mean[k].x - mean[index].x, mean[k].y - mean[index].y);
    if (distance <= max_distance) near.emplace_back(distance, k);
  }
  std::sort(near.begin(), near.end());
  std::vector<NearbyKeyframe> keyframes;
  // The uncertainty costs a covariance recovery each: only the nearest few are asked.
  for (std::size_t i = 0; i < near.size() && i < 4 * count && keyframes.size() < count; ++i) {
    Pose2 relative;
    Eigen::Matrix3d covariance;
    esdf_->relativePose(near[i].second, index, &relative, &covariance);
    // The larger eigenvalue of the 2x2 translation block, in closed form.
    const double a = covariance(0, 0), b = covariance(0, 1), c = covariance(1, 1);
    const double largest = 0.5 * (a + c) + std::hypot(0.5 * (a - c), b);
    if (std::sqrt(std::max(largest, 0.0)) <= max_std) keyframes.push_back({near[i].second, true, relative});
  }
  counters_.seconds += secondsSince(start);
  return keyframes;
}

Eigen::Matrix3d looseLinkCovariance() { return Eigen::Vector3d(1e4, 1e4, 1e2).asDiagonal(); }

std::string SlamBackEnd::addKeyframe(Keyframe keyframe, const Pose2& motion, const Eigen::Matrix3d& covariance) {
  return addKeyframeFrom(keyframes_.empty() ? 0 : keyframes_.size() - 1, std::move(keyframe), motion, covariance);
}

std::string SlamBackEnd::addKeyframeFrom(std::size_t base, Keyframe keyframe, const Pose2& motion,
                                         const Eigen::Matrix3d& covariance) {
  if (!keyframes_.empty() && base >= keyframes_.size())
    throw std::out_of_range("back end: no keyframe " + std::to_string(base) + " to link a new one from");
  std::string note;
  if (keyframe.has_wheel_odometry && !isFinite(keyframe.wheel_odometry)) {
    keyframe.has_wheel_odometry = false;
    note = "wheel odometry not finite: dropped";
  }
  const auto start = std::chrono::steady_clock::now();
  if (!esdf_) {
    esdf_ = std::make_unique<Esdf>(keyframe.has_wheel_odometry ? keyframe.wheel_odometry : Pose2{}, options_);
  } else {
    std::string unusable;
    if (!isFinite(motion) || !usableCovariance(covariance)) {
      unusable = "odometry motion not finite, or its covariance not positive definite";
    } else {
      try {
        esdf_->augmentFrom(base, motion, covariance);
      } catch (const std::invalid_argument& e) {  // the filter's own limits (an information it cannot hold)
        unusable = e.what();
      }
    }
    if (!unusable.empty()) {
      esdf_->augmentFrom(base, isFinite(motion) ? motion : Pose2{}, looseLinkCovariance());
      ++counters_.loosely_linked_keyframes;
      note += (note.empty() ? "" : "; ") + unusable + ": loosely linked instead (the first loop closure places it)";
    }
  }
  keyframes_.push_back(std::move(keyframe));
  ++counters_.keyframes;
  counters_.seconds += secondsSince(start);
  return note;
}

LoopRecord SlamBackEnd::addLoop(const LoopClosure& loop) {
  last_consensus_.clear();
  LoopRecord record;
  record.loop = loop;
  auto refuse = [&](const std::string& why) {
    ++counters_.refused_loops;
    record.refusal = LoopRefusal::kBackEndMalformed;
    record.reject_reason = "backend: " + why;
    loops_.push_back(record);
    return record;
  };
  if (loop.from >= keyframes_.size() || loop.to >= keyframes_.size())
    return refuse("keyframe " + std::to_string(std::max(loop.from, loop.to)) + " is unknown");
  if (loop.from == loop.to) return refuse("a loop from a keyframe to itself");
  if (!isFinite(loop.pose) || !usableCovariance(loop.covariance))
    return refuse("pose not finite, or covariance not positive definite");
  const auto start = std::chrono::steady_clock::now();
  const EsdfUpdateResult update = esdf_->update(loop.from, loop.to, loop.pose, loop.covariance, gate_loops_);
  record.innovation_chi2 = update.innovation_chi2;
  record.applied = update.applied;
  if (update.applied) {
    ++counters_.loops_accepted;
  } else {
    record.refusal = loopRefusalOf(update.refusal);
    record.reject_reason = "backend: " + update.reject_reason;
    ++counters_.refused_by_gate;
  }
  loops_.push_back(record);
  if (refusedByGate(record)) applyByConsensus(loops_.size() - 1);
  counters_.seconds += secondsSince(start);
  return loops_.back();
}

void SlamBackEnd::applyByConsensus(std::size_t index) {
  const LoopRecord& refused = loops_[index];
  const LoopConsensusResult agreed = consensus_.offer(index, refused.loop, refused.innovation_chi2, esdf_->mean());
  for (std::size_t id : agreed.group) {
    LoopRecord& record = loops_[id];
    // Without the gate: each alone missed the map, together they say where it is wrong.
    const EsdfUpdateResult update = esdf_->update(record.loop.from, record.loop.to, record.loop.pose, record.loop.covariance, false);
    if (!update.applied) {  // the filter's own limits (an information it cannot hold): stays refused
      record.refusal = loopRefusalOf(update.refusal);
      record.reject_reason = "backend: " + update.reject_reason + " (applied with " + std::to_string(agreed.group.size() - 1) +
                             " refused loops that agreed)";
      continue;
    }
    record.applied = true;
    record.by_consensus = true;
    record.refusal = LoopRefusal::kNone;
    record.reject_reason.clear();
    ++counters_.loops_accepted;
    ++counters_.applied_by_consensus;
    --counters_.refused_by_gate;
    last_consensus_.push_back(id);
  }
}

std::string SlamBackEnd::restore(const SlamSession& session) {
  const std::string invalid = session.validate();
  if (!invalid.empty()) return invalid;
  std::unique_ptr<Esdf> esdf;
  if (!session.keyframes.empty()) {
    const Keyframe& first = session.keyframes.front();
    try {
      esdf = std::make_unique<Esdf>(first.has_wheel_odometry ? first.wheel_odometry : Pose2{}, options_);
      for (const PoseEdge& edge : session.constraints) {
        if (edge.to == esdf->size()) {
          esdf->augmentWithInformation(edge);
        } else {
          const EsdfUpdateResult update = esdf->updateWithInformation(edge, false, false);
          if (!update.applied) return "constraint " + std::to_string(edge.from) + " -> " + std::to_string(edge.to) + ": " + update.reject_reason;
        }
      }
      esdf->solveFrom(session.poses);
    } catch (const std::exception& e) {
      return std::string("the graph cannot be rebuilt: ") + e.what();
    }
  }
  esdf_ = std::move(esdf);
  keyframes_ = session.keyframes;
  loops_ = session.loops;
  counters_ = BackEndCounters{};
  counters_.keyframes = keyframes_.size();
  consensus_.clear();
  last_consensus_.clear();
  for (std::size_t i = 0; i < loops_.size(); ++i) {
    const LoopRecord& record = loops_[i];
    counters_.applied_by_consensus += record.by_consensus;
    if (record.applied) ++counters_.loops_accepted;
    else if (record.innovation_chi2 > 0.0) ++counters_.refused_by_gate;
    else ++counters_.refused_loops;
    // Waiting again, as they were (none had found enough others that agree).
    if (refusedByGate(record)) consensus_.keep(i, record.loop, record.innovation_chi2);
  }
  return "";
}

}  // namespace llc
