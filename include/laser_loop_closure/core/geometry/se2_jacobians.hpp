// Jacobians of the SE(2) compounding operators of se2.hpp (Smith, Self & Cheeseman), with
// poses as (x, y, theta) vectors; what the ESDF linearises its motion and measurement models with.
#pragma once

#include <Eigen/Core>

#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc {

inline Eigen::Vector3d toVector(const Pose2& p) { return {p.x, p.y, p.theta}; }
inline Pose2 toPose(const Eigen::Vector3d& v) { return {v.x(), v.y(), normalizeAngle(v.z())}; }
/// The additive step from q to p (x, y subtracted, theta subtracted and wrapped): the
/// coordinates in which a linearised pose graph's unknowns live.
inline Eigen::Vector3d poseDifference(const Pose2& p, const Pose2& q) {
  return {p.x - q.x, p.y - q.y, normalizeAngle(p.theta - q.theta)};
}

/// d(a (+) b)/da and d(a (+) b)/db.
inline void composeJacobians(const Pose2& a, const Pose2& b, Eigen::Matrix3d* ja, Eigen::Matrix3d* jb) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  if (ja) *ja << 1, 0, -s * b.x - c * b.y, 0, 1, c * b.x - s * b.y, 0, 0, 1;
  if (jb) *jb << c, -s, 0, s, c, 0, 0, 0, 1;
}

/// d((-)a)/da.
inline Eigen::Matrix3d inverseJacobian(const Pose2& a) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  Eigen::Matrix3d j;
  j << -c, -s, s * a.x - c * a.y, s, -c, c * a.x + s * a.y, 0, 0, -1;
  return j;
}

/// d(between(a, b))/da and d(between(a, b))/db, between(a, b) = (-)a (+) b.
inline void betweenJacobians(const Pose2& a, const Pose2& b, Eigen::Matrix3d* ja, Eigen::Matrix3d* jb) {
  Eigen::Matrix3d j_first, j_second;
  composeJacobians(inverse(a), b, &j_first, &j_second);
  if (ja) *ja = j_first * inverseJacobian(a);
  if (jb) *jb = j_second;
}

}  // namespace llc
