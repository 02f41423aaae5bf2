// Odometry that drifts like a real wheelbase, for logs whose odometry is perfect (the
// `*-corrected` CARMEN logs carry the corrected poses as odometry, so mapping them tests
// nothing). Each step between consecutive odometry poses is scaled, turned by a heading drift
// per metre and given seeded noise, then the poses are integrated again from the first one.
// The truth is not touched: a map built from the drifted odometry is scored against it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "laser_loop_closure/core/io/scan_sequence.hpp"
#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc {

struct OdometryDrift {
  double scale_bias = 0.015;        ///< each step's translation is (1 + scale_bias) times the true one
  double heading_drift = 0.005;     ///< rad of heading error added per metre driven (a wheel-radius mismatch)
  double noise_translation = 0.01;  ///< m; standard deviation of each step's noise on x and y
  double noise_rotation = 0.002;    ///< rad; standard deviation of each step's noise on the heading
  double noise_fraction = 0.02;     ///< added to those: this share of the step's length (m) and turn (rad)
  std::uint64_t seed = 1;           ///< the same seed gives the same drift
  /// "" or what is wrong (a non-finite value, a negative noise, a scale bias of -1 or below).
  [[nodiscard]] std::string validate() const;
};

/// The drifted odometry poses: the first pose kept, every step degraded as above. Throws
/// std::invalid_argument on invalid options.
std::vector<Pose2> driftOdometry(const std::vector<Pose2>& odometry, const OdometryDrift& drift);

/// Replaces the sequence's odometry by driftOdometry of it; the truth stays. Throws
/// std::invalid_argument when the sequence has no odometry or the options are invalid.
void driftOdometry(ScanSequence* sequence, const OdometryDrift& drift);

}  // namespace llc
