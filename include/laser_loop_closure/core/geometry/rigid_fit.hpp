// The rigid transform that best maps one set of points onto their partners: closed-form
// weighted least squares, and a robust version for associations that contain outliers.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "laser_loop_closure/core/geometry/point_cloud.hpp"

namespace llc {

/// One association: source point -> target point, with a weight (confidence) >= 0.
struct Correspondence2 {
  Point2 source;
  Point2 target;
  double weight = 1.0;
};

/// The pose T minimising sum w |T(source) - target|^2 (closed form; Kabsch/Umeyama in 2D).
/// False when the total weight is zero or the weighted source points are all at one place
/// (then rotation is undetermined).
bool fitRigid(const std::vector<Correspondence2>& correspondences, Pose2* pose);

struct RobustFitOptions {
  double inlier_distance = 0.3;   ///< m; an association farther than this from the fit is an outlier
  int hypotheses = 200;           ///< random two-association hypotheses tried (RANSAC)
  std::uint64_t seed = 1;         ///< seeds the choice of hypotheses (deterministic results)
  int alternatives = 3;           ///< also return up to this many other distinct transforms ...
  double distinct_distance = 0.5;  ///< m; ... differing from better ones by more than this ...
  double distinct_angle = 0.17;    ///< rad; ... or this (about 10 degrees)
  [[nodiscard]] std::string validate() const;
};

struct RobustFitResult {
  bool ok = false;
  Pose2 pose;
  double inlier_weight = 0.0;     ///< total weight of the inliers of the final fit
  std::size_t inlier_count = 0;
  std::vector<char> inlier;       ///< per correspondence
  /// Runners-up, best first (each refined like the winner): transforms that a later stage
  /// may try when the best one turns out wrong (repetitive structure, symmetric rooms).
  std::vector<Pose2> alternatives;
};

/// RANSAC over pairs of associations (scored by inlier weight), then weighted least squares
/// on the inliers, repeated until the inlier set stops changing; the same for the best few
/// distinct runners-up.
RobustFitResult fitRigidRobust(const std::vector<Correspondence2>& correspondences, const RobustFitOptions& options);

}  // namespace llc
