#include "laser_loop_closure/core/geometry/trajectory_error.hpp"

#include <cmath>
#include <stdexcept>

namespace llc {

double alignedRmsError(const std::vector<Pose2>& estimate, const std::vector<Pose2>& truth, Pose2* alignment) {
  if (estimate.size() != truth.size()) throw std::invalid_argument("alignedRmsError: as many estimates as true poses needed");
  const std::size_t n = estimate.size();
  if (n == 0) return 0.0;
  double ex = 0, ey = 0, tx = 0, ty = 0;
  for (std::size_t i = 0; i < n; ++i) ex += estimate[i].x, ey += estimate[i].y, tx += truth[i].x, ty += truth[i].y;
  ex /= double(n), ey /= double(n), tx /= double(n), ty /= double(n);
  // The rotation maximising sum of truth . R estimate (centred): atan2 of the cross and dot sums.
  double dot = 0, cross = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double ax = estimate[i].x - ex, ay = estimate[i].y - ey, bx = truth[i].x - tx, by = truth[i].y - ty;
    dot += ax * bx + ay * by;
    cross += ax * by - ay * bx;
  }
  const double angle = n > 1 ? std::atan2(cross, dot) : 0.0;
  const double c = std::cos(angle), s = std::sin(angle);
  const Pose2 motion{tx - (c * ex - s * ey), ty - (s * ex + c * ey), normalizeAngle(angle)};
  double sum = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Pose2 moved = compose(motion, estimate[i]);
    sum += (moved.x - truth[i].x) * (moved.x - truth[i].x) + (moved.y - truth[i].y) * (moved.y - truth[i].y);
  }
  if (alignment) *alignment = motion;
  return std::sqrt(sum / double(n));
}

}  // namespace llc
