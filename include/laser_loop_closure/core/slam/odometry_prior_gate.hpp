// The back end's chi-square gate on a loop between two scans of a log, with only the front
// end's odometry chain between them as the prior (keyframes and ICP steps as `llc slam` makes
// them, no loop closed yet). `llc evaluate --leave-one-log-out --validate --drift ...` runs the
// full loop stage held out with it: classifier -> alignment -> shape validation -> this gate.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <vector>

#include "laser_loop_closure/core/backend/esdf.hpp"
#include "laser_loop_closure/core/features/features.hpp"
#include "laser_loop_closure/core/geometry/scan.hpp"
#include "laser_loop_closure/core/alignment/scan_aligner.hpp"
#include "laser_loop_closure/core/slam/scan_odometry.hpp"
#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc {

class OdometryPriorGate {
 public:
  /// scan_odometry: one wheel-odometry pose per scan; keyframe k was made from scan
  /// keyframe_scans[k] (increasing), steps[k] is its motion from keyframe k-1 with its
  /// covariance (steps[0] is not used). Throws std::invalid_argument when they do not fit.
  OdometryPriorGate(const std::vector<Pose2>& scan_odometry, const std::vector<std::size_t>& keyframe_scans,
                    const std::vector<OdometryStep>& steps, const EsdfOptions& esdf = {});
  /// The chain the front end makes of these scans (SlamFrontEnd::addScan: keyframes, ICP seeded
  /// by the wheels, disputed steps), with the odometry options and scan preparation given.
  static OdometryPriorGate fromFrontEnd(const std::vector<Scan>& scans, const std::vector<Pose2>& scan_odometry,
                                        const ScanOdometryOptions& odometry, const ScanAlignerOptions& aligner,
                                        const FeatureOptions& features, const EsdfOptions& esdf = {});
  OdometryPriorGate(OdometryPriorGate&&) noexcept;
  ~OdometryPriorGate();

  /// Innovation chi-square of a loop (scan b in scan a's frame, with its covariance) against
  /// the chain's prediction, as Esdf::update tests it. A scan between keyframes is carried to
  /// the keyframe before it by its wheel odometry, taken as exact (less than a keyframe step).
  /// Throws std::out_of_range for an unknown scan or one before the first keyframe,
  /// std::invalid_argument when a is newer than b.
  double chi2(std::size_t a, std::size_t b, const Pose2& loop, const Eigen::Matrix3d& covariance);
  /// Esdf::update would refuse the loop (chi2 above EsdfOptions::loop_chi2_threshold).
  bool refuses(std::size_t a, std::size_t b, const Pose2& loop, const Eigen::Matrix3d& covariance);
  std::size_t keyframes() const { return keyframe_scans_.size(); }

 private:
  std::vector<Pose2> odometry_;
  std::vector<std::size_t> keyframe_scans_;
  double threshold_;
  std::unique_ptr<Esdf> esdf_;
};

}  // namespace llc
