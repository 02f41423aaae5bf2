// Scans ray-cast in small synthetic worlds, shared by the alignment tests.
#pragma once

#include <cmath>
#include <limits>
#include <vector>

#include "laser_loop_closure/core/geometry/point_cloud.hpp"
#include "laser_loop_closure/core/common/random.hpp"
#include "test_util.hpp"

namespace llc_test {

using llc::Point2;
using llc::Pose2;

struct Wall {
  Point2 a, b;
};

/// An irregular room (12 x 8 m with an alcove and a slanted corner) with two square pillars:
/// no symmetry, so every pose is determined.
inline std::vector<Wall> room() {
  const std::vector<Point2> outline = {{-6, -4}, {3, -4}, {6, -1.5}, {6, 4}, {1, 4}, {1, 5.5},
                                       {-1.5, 5.5}, {-1.5, 4}, {-6, 4}};
  std::vector<Wall> walls;
  for (std::size_t i = 0; i < outline.size(); ++i) walls.push_back({outline[i], outline[(i + 1) % outline.size()]});
  auto box = [&](Point2 c, double h) {
    const Point2 p[4] = {c + Point2(-h, -h), c + Point2(h, -h), c + Point2(h, h), c + Point2(-h, h)};
    for (int k = 0; k < 4; ++k) walls.push_back({p[k], p[(k + 1) % 4]});
  };
  box({-3.0, 1.5}, 0.3);
  box({2.5, -1.0}, 0.2);
  return walls;
}

/// Two parallel walls 3 m apart and 200 m long: nothing fixes the position along them.
inline std::vector<Wall> corridor() { return {{{-100, -1.5}, {100, -1.5}}, {{-100, 1.5}, {100, 1.5}}}; }

inline double castRay(const std::vector<Wall>& walls, const Point2& origin, double angle) {
  const Point2 d(std::cos(angle), std::sin(angle));
  double best = std::numeric_limits<double>::infinity();
  for (const Wall& w : walls) {
    const Point2 e = w.b - w.a;
    const double denom = d.x() * e.y() - d.y() * e.x();
    if (std::abs(denom) < 1e-12) continue;
    const Point2 o = w.a - origin;
    const double t = (o.x() * e.y() - o.y() * e.x()) / denom;
    const double u = (o.x() * d.y() - o.y() * d.x()) / denom;
    if (t > 0.0 && u >= 0.0 && u <= 1.0) best = std::min(best, t);
  }
  return best;
}

/// A 360-degree scan of `beams` beams taken at `pose`, with Gaussian range noise.
inline llc::Scan scanAt(const std::vector<Wall>& walls, const Pose2& pose, std::size_t beams = 720, double noise = 0.0,
                 std::uint64_t seed = 1) {
  std::vector<double> ranges(beams);
  llc::Random random(seed);
  for (std::size_t i = 0; i < beams; ++i) {
    const double bearing = -M_PI + 2.0 * M_PI * double(i) / double(beams);
    ranges[i] = castRay(walls, {pose.x, pose.y}, pose.theta + bearing);
    if (std::isfinite(ranges[i]) && noise > 0.0) ranges[i] += random.normal(0.0, noise);
  }
  return ringScan(ranges);
}

}  // namespace llc_test
