// SE(2) poses and the compounding operator of Smith, Self & Cheeseman (the paper's eq. 26).
#pragma once

#include <cmath>

namespace llc {

/// Wraps an angle to [-pi, pi).
inline double normalizeAngle(double angle) {
  if (!std::isfinite(angle)) return angle;
  angle = std::fmod(angle + M_PI, 2.0 * M_PI);
  if (angle < 0.0) angle += 2.0 * M_PI;
  return angle - M_PI;
}

/// A planar pose (metres, radians); theta is kept in [-pi, pi).
struct Pose2 {
  double x = 0.0;
  double y = 0.0;
  double theta = 0.0;
};

/// a (+) b: pose b, expressed in the frame of a, moved into a's parent frame.
/// All three numbers finite (a pose from a message or a log may not be).
inline bool isFinite(const Pose2& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.theta); }

inline Pose2 compose(const Pose2& a, const Pose2& b) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  return {a.x + c * b.x - s * b.y, a.y + s * b.x + c * b.y, normalizeAngle(a.theta + b.theta)};
}

/// (-)a: the inverse pose, so that compose(a, inverse(a)) is the identity.
inline Pose2 inverse(const Pose2& a) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  return {-c * a.x - s * a.y, s * a.x - c * a.y, normalizeAngle(-a.theta)};
}

/// Pose of b in the frame of a: (-)a (+) b.
inline Pose2 between(const Pose2& a, const Pose2& b) { return compose(inverse(a), b); }

}  // namespace llc
