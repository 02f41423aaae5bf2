#include "laser_loop_closure/core/sim/odometry_drift.hpp"

#include <cmath>
#include <stdexcept>

#include "laser_loop_closure/core/common/random.hpp"

namespace llc {

std::string OdometryDrift::validate() const {
  for (double v : {scale_bias, heading_drift, noise_translation, noise_rotation, noise_fraction})
    if (!std::isfinite(v)) return "odometry drift: every value must be finite";
  if (!(scale_bias > -1.0)) return "odometry drift: scale_bias must be above -1";
  if (noise_translation < 0.0 || noise_rotation < 0.0 || noise_fraction < 0.0) return "odometry drift: noises must not be negative";
  return "";
}

std::vector<Pose2> driftOdometry(const std::vector<Pose2>& odometry, const OdometryDrift& drift) {
  const std::string invalid = drift.validate();
  if (!invalid.empty()) throw std::invalid_argument(invalid);
  std::vector<Pose2> drifted;
  drifted.reserve(odometry.size());
  Random random(drift.seed);
  for (std::size_t k = 0; k < odometry.size(); ++k) {
    if (k == 0) {
      drifted.push_back(odometry[0]);
      continue;
    }
    const Pose2 step = between(odometry[k - 1], odometry[k]);
    const double length = std::hypot(step.x, step.y);
    const double sigma_xy = drift.noise_translation + drift.noise_fraction * length;
    const double sigma_theta = drift.noise_rotation + drift.noise_fraction * std::abs(step.theta);
    // Three draws a step whatever the sigmas, so a seed gives the same sequence of draws.
    const double nx = random.normal(0.0, 1.0), ny = random.normal(0.0, 1.0), nt = random.normal(0.0, 1.0);
    Pose2 degraded;
    degraded.x = (1.0 + drift.scale_bias) * step.x + sigma_xy * nx;
    degraded.y = (1.0 + drift.scale_bias) * step.y + sigma_xy * ny;
    degraded.theta = normalizeAngle(step.theta + drift.heading_drift * length + sigma_theta * nt);
    drifted.push_back(compose(drifted.back(), degraded));
  }
  return drifted;
}

void driftOdometry(ScanSequence* sequence, const OdometryDrift& drift) {
  if (!sequence->has_odometry) throw std::invalid_argument("odometry drift: the input has no odometry to degrade");
  std::vector<Pose2> odometry;
  for (const LoggedScan& s : sequence->scans) odometry.push_back(s.odometry);
  const std::vector<Pose2> drifted = driftOdometry(odometry, drift);
  for (std::size_t k = 0; k < drifted.size(); ++k) sequence->scans[k].odometry = drifted[k];
}

}  // namespace llc
