// Point-to-line ICP in the plane (Chen & Medioni): refines the pose of a source scan in the
// frame of a target scan from a starting guess, with a k-d tree, trimming and a Huber loss.
#pragma once

#include <Eigen/Core>
#include <string>

#include "laser_loop_closure/core/geometry/point_cloud.hpp"

namespace llc {

struct FieldOfView;

struct IcpOptions {
  int max_iterations = 40;                 ///< Gauss-Newton steps at most
  double max_correspondence_distance = 1.5;  ///< m; farther nearest neighbours are not paired
  double trim_fraction = 0.9;              ///< share of the nearest pairs kept each step (trimmed ICP)
  double huber_delta = 0.05;               ///< m; point-to-line residuals beyond this weigh less
  double translation_tolerance = 1e-3;     ///< m; converged when a step moves less than this ...
  double rotation_tolerance = 1e-3;        ///< rad; ... and turns less than this
  int min_correspondences = 10;            ///< fewer pairs than this: not converged
  double degeneracy_ratio = 1e-3;          ///< smallest / largest eigenvalue of the normalised
                                           ///< Hessian below this: a direction is unconstrained
  /// A direction of the normalised Hessian whose eigenvalue is below this x the largest is
  /// weakly constrained (a corridor's axis): ICP takes no step along it, and the pose keeps the
  /// seed's there (solution remapping). 0: off.
  double remap_ratio = 0.0;
  int normal_neighbours = 6;               ///< points used for each target normal
  double normal_radius = 0.6;              ///< m; neighbours beyond this do not shape a normal
  std::size_t max_source_points = 400;     ///< source points paired per step, evenly strided (0 = all)
  double max_normal_angle = 0.5;           ///< rad; pairs whose normals differ more are dropped (when given)
  /// Steps after which the pairs stay as they are: the trimmed pair set can flip between two
  /// states for ever (a limit cycle 2 mm to 2 cm wide), while with fixed pairs Gauss-Newton
  /// settles. At or beyond max_iterations: the pairs are found afresh at every step.
  int fixed_pairs_after = 30;
  [[nodiscard]] std::string validate() const;
};

/// The target scan with what ICP needs of it, built once and reusable for many sources.
struct IcpTarget {
  IcpTarget(Points2 points, const IcpOptions& options);
  /// With the points' normals already known (one per point, e.g. moved from the scans they
  /// came from); throws std::invalid_argument when the counts differ.
  IcpTarget(Points2 points, Points2 known_normals);
  KdTree2 tree;
  Points2 normals;  ///< unit, or zero where the point has no surface around it
};

struct IcpResult {
  bool converged = false;
  Pose2 pose;                      ///< source frame in the target frame
  /// Covariance of pose (x, y, theta) as a small motion applied in the target frame:
  /// sigma^2 (J^T W J)^-1, sigma^2 the weighted residual variance.
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
  int iterations = 0;
  std::size_t correspondences = 0;  ///< pairs used in the last step
  double rms_residual = 0.0;        ///< m, point-to-line, over those pairs
  double seconds = 0.0;
  std::string reject_reason;        ///< empty when converged
};

/// Refines `initial` (source frame in target frame). Never throws on bad geometry: an empty
/// or degenerate input (e.g. a straight corridor) gives converged = false with the reason.
/// With source_normals (one per source point, as estimateNormals gives them), a pair whose
/// normals differ by more than max_normal_angle is not used: a wall does not match a wall
/// across it. With target_view, a source point the target's scanner could not have seen (out
/// of its bearings or range) is not paired: it has no partner there, and the nearest points at
/// the edge of the view would pull the pose towards them.
IcpResult alignIcp(const Points2& source, const IcpTarget& target, const Pose2& initial, const IcpOptions& options,
                   const Points2* source_normals = nullptr, const FieldOfView* target_view = nullptr);

}  // namespace llc
