#include "laser_loop_closure/core/alignment/icp.hpp"

#include "laser_loop_closure/core/alignment/shape_validation.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

namespace llc {

std::string IcpOptions::validate() const {
  if (max_iterations < 1) return "max_iterations must be >= 1";
  if (!(max_correspondence_distance > 0.0)) return "max_correspondence_distance must be > 0";
  if (!(trim_fraction > 0.0 && trim_fraction <= 1.0)) return "trim_fraction must be in (0, 1]";
  if (!(huber_delta > 0.0)) return "huber_delta must be > 0";
  if (!(translation_tolerance > 0.0) || !(rotation_tolerance > 0.0)) return "tolerances must be > 0";
  if (min_correspondences < 3) return "min_correspondences must be >= 3";
  if (!(degeneracy_ratio >= 0.0 && degeneracy_ratio < 1.0)) return "degeneracy_ratio must be in [0, 1)";
  if (!(remap_ratio >= 0.0 && remap_ratio < 1.0)) return "remap_ratio must be in [0, 1)";
  if (normal_neighbours < 2) return "normal_neighbours must be >= 2";
  if (!(normal_radius > 0.0)) return "normal_radius must be > 0";
  if (!(max_normal_angle > 0.0 && max_normal_angle <= M_PI / 2)) return "max_normal_angle must be in (0, pi/2]";
  if (fixed_pairs_after < 1) return "fixed_pairs_after must be >= 1";
  return "";
}

IcpTarget::IcpTarget(Points2 points, const IcpOptions& options)
    : tree(std::move(points)), normals(estimateNormals(tree, std::size_t(options.normal_neighbours), options.normal_radius)) {}

IcpTarget::IcpTarget(Points2 points, Points2 known_normals) : tree(std::move(points)), normals(std::move(known_normals)) {
  if (normals.size() != tree.size()) throw std::invalid_argument("IcpTarget: one normal per point is needed");
}

namespace {
struct Pair {
  Point2 moved;   // source point under the current pose
  Point2 normal;  // target normal
  double residual;
  double distance_sq;
  std::size_t source_index, target_index;
};

/// Pairs every stride-th source point (moved by motion) with its nearest target point, then
/// keeps the nearest trim_fraction of the pairs.
void findPairs(const Points2& source, const IcpTarget& target, const RigidMotion2& motion, const IcpOptions& options,
               std::size_t stride, const Points2* source_normals, const FieldOfView* target_view,
               std::vector<Pair>* pairs) {
  pairs->clear();
  const double gate_sq = options.max_correspondence_distance * options.max_correspondence_distance;
  const double min_normal_cos = std::cos(options.max_normal_angle);
  for (std::size_t k = 0; k < source.size(); k += stride) {
    const Point2 moved = motion(source[k]);
    if (target_view && !target_view->contains(moved)) continue;
    std::size_t index;
    double distance_sq;
    if (!target.tree.nearest(moved, &index, &distance_sq, gate_sq) || distance_sq > gate_sq) continue;
    const Point2& normal = target.normals[index];
    if (normal.isZero()) continue;
    if (source_normals) {
      // Normals are unsigned (PCA), so compare |cos| of the angle between them.
      const Point2& n = (*source_normals)[k];
      if (!n.isZero() && std::abs(n.x() * (motion.c * normal.x() + motion.s * normal.y()) +
                                  n.y() * (-motion.s * normal.x() + motion.c * normal.y())) < min_normal_cos)
        continue;
    }
    pairs->push_back({moved, normal, normal.dot(moved - target.tree.points()[index]), distance_sq, k, index});
  }
  // Trimmed: only the nearest share of the pairs, which drops the parts one scan sees and
  // the other does not.
  const std::size_t keep = std::size_t(std::ceil(options.trim_fraction * double(pairs->size())));
  if (keep < pairs->size()) {
    std::nth_element(pairs->begin(), pairs->begin() + long(keep), pairs->end(),
                     [](const Pair& a, const Pair& b) { return a.distance_sq < b.distance_sq; });
    pairs->resize(keep);
  }
}

}  // namespace

IcpResult alignIcp(const Points2& source, const IcpTarget& target, const Pose2& initial, const IcpOptions& options,
                   const Points2* source_normals, const FieldOfView* target_view) {
  const auto start = std::chrono::steady_clock::now();
  IcpResult result;
  result.pose = initial;
  auto finish = [&](const char* reason) {
    result.reject_reason = reason;
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
  };
  if (source.size() < std::size_t(options.min_correspondences) || target.tree.size() < std::size_t(options.min_correspondences))
    return finish("too few points");
  if (!(std::isfinite(initial.x) && std::isfinite(initial.y) && std::isfinite(initial.theta)))
    return finish("initial pose not finite");
  // Every stride-th source point: enough to constrain three parameters, and cheaper.
  const std::size_t stride = options.max_source_points > 0 ? (source.size() + options.max_source_points - 1) / options.max_source_points : 1;
  std::vector<Pair> pairs;
  pairs.reserve(source.size());
  Eigen::Matrix3d hessian = Eigen::Matrix3d::Zero();
  double weighted_sq = 0.0, weight_sum = 0.0;
  for (int iteration = 1; iteration <= options.max_iterations; ++iteration) {
    result.iterations = iteration;
    const RigidMotion2 motion(result.pose);
    if (iteration > options.fixed_pairs_after) {
      for (Pair& pair : pairs) {  // the same pairs, moved with the pose
        const Point2& partner = target.tree.points()[pair.target_index];
        pair.moved = motion(source[pair.source_index]);
        pair.residual = pair.normal.dot(pair.moved - partner);
      }
    } else {
      findPairs(source, target, motion, options, stride, source_normals, target_view, &pairs);
    }
    result.correspondences = pairs.size();
    if (pairs.size() < std::size_t(options.min_correspondences)) return finish("too few correspondences");
    // Linearised about the moved points: a small motion (dx, dy, dtheta) applied in the target
    // frame changes the residual n . (p + dtheta perp(p) + d - q) to first order.
    hessian.setZero();
    Eigen::Vector3d gradient = Eigen::Vector3d::Zero();
    weighted_sq = 0.0, weight_sum = 0.0;
    for (const Pair& pair : pairs) {
      const double magnitude = std::abs(pair.residual);
      const double weight = magnitude <= options.huber_delta ? 1.0 : options.huber_delta / magnitude;
      const Eigen::Vector3d j(pair.normal.x(), pair.normal.y(),
                              pair.normal.y() * pair.moved.x() - pair.normal.x() * pair.moved.y());
      hessian += weight * j * j.transpose();
      gradient += weight * pair.residual * j;
      weighted_sq += weight * pair.residual * pair.residual;
      weight_sum += weight;
    }
    result.rms_residual = std::sqrt(weighted_sq / weight_sum);
    // Degenerate geometry (a straight corridor, one wall): a direction the pairs do not
    // constrain. Rotation is scaled by the points' spread so the ratio has no unit.
    double spread = 0.0;
    for (const Pair& pair : pairs) spread += pair.moved.squaredNorm();
    const double scale = std::sqrt(std::max(spread / double(pairs.size()), 1e-6));
    const Eigen::Vector3d unit(1.0, 1.0, 1.0 / scale);
    const Eigen::Matrix3d normalised = unit.asDiagonal() * hessian * unit.asDiagonal();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(normalised);
    const Eigen::Vector3d eigen = solver.eigenvalues();
    if (!(eigen(0) > options.degeneracy_ratio * eigen(2))) return finish("degenerate geometry");
    const Eigen::Matrix3d& system = hessian;
    Eigen::Vector3d step = -system.ldlt().solve(gradient);
    if (options.remap_ratio > 0.0) {
      // Solution remapping (Zhang, Kaess, Singh 2016): no step along a direction the pairs
      // hardly constrain (a corridor's axis), so there the pose stays where the seed put it.
      Eigen::Matrix3d keep = Eigen::Matrix3d::Zero();
      for (int i = 0; i < 3; ++i)
        if (eigen(i) >= options.remap_ratio * eigen(2)) keep += solver.eigenvectors().col(i) * solver.eigenvectors().col(i).transpose();
      step = unit.asDiagonal() * (keep * (unit.cwiseInverse().asDiagonal() * step));
    }
    if (!step.allFinite()) return finish("numerical failure");
    result.pose = compose(Pose2{step(0), step(1), step(2)}, result.pose);
    if (std::hypot(step(0), step(1)) < options.translation_tolerance && std::abs(step(2)) < options.rotation_tolerance) {
      result.converged = true;
      break;
    }
  }
  if (!result.converged) return finish("no convergence within max_iterations");
  const double dof = std::max(1.0, double(result.correspondences) - 3.0);
  const double variance = std::max(weighted_sq / weight_sum * double(result.correspondences) / dof, 1e-8);
  result.covariance = variance * hessian.inverse();
  return finish("");
}

}  // namespace llc
