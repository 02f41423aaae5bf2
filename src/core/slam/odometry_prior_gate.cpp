#include "laser_loop_closure/core/slam/odometry_prior_gate.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <stdexcept>
#include <string>

#include "laser_loop_closure/core/classifier/classifier_model.hpp"
#include "laser_loop_closure/core/slam/loop_detector.hpp"
#include "laser_loop_closure/core/slam/slam_front_end.hpp"

namespace llc {

OdometryPriorGate::OdometryPriorGate(const std::vector<Pose2>& scan_odometry, const std::vector<std::size_t>& keyframe_scans,
                                     const std::vector<OdometryStep>& steps, const EsdfOptions& esdf)
    : odometry_(scan_odometry), keyframe_scans_(keyframe_scans), threshold_(esdf.loop_chi2_threshold) {
  if (keyframe_scans_.empty() || steps.size() != keyframe_scans_.size())
    throw std::invalid_argument("odometry prior gate: one step per keyframe, at least one keyframe");
  for (std::size_t k = 0; k < keyframe_scans_.size(); ++k)
    if (keyframe_scans_[k] >= odometry_.size() || (k > 0 && keyframe_scans_[k] <= keyframe_scans_[k - 1]))
      throw std::invalid_argument("odometry prior gate: keyframe scans must increase and name scans");
  esdf_ = std::make_unique<Esdf>(Pose2{}, esdf);
  for (std::size_t k = 1; k < steps.size(); ++k) esdf_->augment(steps[k].motion, steps[k].covariance);
}

OdometryPriorGate OdometryPriorGate::fromFrontEnd(const std::vector<Scan>& scans, const std::vector<Pose2>& scan_odometry,
                                                  const ScanOdometryOptions& odometry, const ScanAlignerOptions& aligner,
                                                  const FeatureOptions& features, const EsdfOptions& esdf) {
  if (scans.size() != scan_odometry.size()) throw std::invalid_argument("odometry prior gate: one odometry pose per scan");
  ClassifierModel describe_only;  // the front end stores features; no loop is looked for here
  describe_only.features = features;
  SlamFrontEnd front(describe_only, odometry, aligner, LoopDetectorOptions{});
  std::vector<std::size_t> keyframe_scans;
  std::vector<OdometryStep> steps;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    const FrontEndStep step = front.addScan(scans[i], &scan_odometry[i]);
    if (!step.keyframe) continue;
    keyframe_scans.push_back(i);
    steps.push_back(step.odometry);
  }
  return OdometryPriorGate(scan_odometry, keyframe_scans, steps, esdf);
}

OdometryPriorGate::OdometryPriorGate(OdometryPriorGate&&) noexcept = default;
OdometryPriorGate::~OdometryPriorGate() = default;

double OdometryPriorGate::chi2(std::size_t a, std::size_t b, const Pose2& loop, const Eigen::Matrix3d& covariance) {
  if (a >= odometry_.size() || b >= odometry_.size())
    throw std::out_of_range("odometry prior gate: no scan " + std::to_string(a >= odometry_.size() ? a : b));
  if (a > b) throw std::invalid_argument("odometry prior gate: scan a must not be newer than scan b");
  if (a < keyframe_scans_.front()) throw std::out_of_range("odometry prior gate: scan " + std::to_string(a) + " is before the first keyframe");
  // The newest keyframe at or before each scan.
  const auto keyframeOf = [&](std::size_t scan) {
    return std::size_t(std::upper_bound(keyframe_scans_.begin(), keyframe_scans_.end(), scan) - keyframe_scans_.begin()) - 1;
  };
  const std::size_t ka = keyframeOf(a), kb = keyframeOf(b);
  // The loop between the scans' keyframes: keyframe a -> scan a -> (loop) -> scan b -> keyframe b.
  const Pose2 to_a = between(odometry_[keyframe_scans_[ka]], odometry_[a]);
  const Pose2 to_b = between(odometry_[keyframe_scans_[kb]], odometry_[b]);
  const Pose2 between_keyframes = compose(compose(to_a, loop), inverse(to_b));
  if (ka == kb) {
    // One keyframe: the prediction is the identity, known exactly; only the loop is uncertain.
    const Eigen::Vector3d e(between_keyframes.x, between_keyframes.y, between_keyframes.theta);
    return e.dot(covariance.ldlt().solve(e));
  }
  return esdf_->innovationChi2(ka, kb, between_keyframes, covariance);
}

bool OdometryPriorGate::refuses(std::size_t a, std::size_t b, const Pose2& loop, const Eigen::Matrix3d& covariance) {
  return !(chi2(a, b, loop, covariance) <= threshold_);
}

}  // namespace llc
