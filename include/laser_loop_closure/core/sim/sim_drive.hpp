// A drive through the simulated city: a route on the streets that comes back to earlier
// places from the same and the opposite direction, a car with a front and a back 180-degree
// scanner, wheel odometry with drift, and ground truth.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "laser_loop_closure/core/geometry/scan.hpp"
#include "laser_loop_closure/core/geometry/se2.hpp"
#include "laser_loop_closure/core/sim/sim_world.hpp"

namespace llc {

struct SimScannerOptions {
  std::string name;            ///< "front" or "back"
  Pose2 mount;                 ///< scanner pose in the vehicle's base frame
  std::size_t beams = 361;     ///< over 180 degrees from -90 (0.5-degree steps)
  double max_range = 80.0;     ///< m; no return beyond it
  double range_noise = 0.02;   ///< m, standard deviation
  double dropout = 0.005;      ///< probability that a beam reports no return
};

struct SimDriveOptions {
  std::uint64_t seed = 1;        ///< the world and everything random in the drive
  /// The route and the noise alone (0: seed): another route through the same city.
  std::uint64_t route_seed = 0;
  double length_m = 2000.0;      ///< m of route
  double rate_hz = 10.0;         ///< scans per second
  double speed = 7.0;            ///< m/s on straights (half of it in turns)
  bool back_scanner = true;      ///< false: front scanner only
  double parking_mean_s = 1800.0;  ///< s; mean time a parking slot stays occupied or free
  double odometry_distance_noise = 0.02;  ///< relative standard deviation of each step's length
  double odometry_turn_noise = 0.02;      ///< relative standard deviation of each step's turn
  double odometry_turn_per_metre = 0.002; ///< rad/m, standard deviation of heading drift
  double odometry_scale_bias = 0.01;      ///< relative; wheels a little too big
  double odometry_turn_bias = 0.0005;     ///< rad/m, a constant pull

  /// Empty when usable, else a sentence saying what is wrong.
  [[nodiscard]] std::string validate() const;
};

struct SimFrame {
  double stamp = 0.0;    ///< s
  Pose2 truth;           ///< base_link in the world
  Pose2 odometry;        ///< base_link in odom
  std::vector<double> front, back;  ///< ranges, +inf where no return (back empty without it)
};

struct SimDrive {
  SimDriveOptions options;
  SimScannerOptions front, back;
  std::vector<SimFrame> frames;
  std::vector<Pose2> route;  ///< the route's waypoints (intersections), for the picture
  double seconds_to_simulate = 0.0;
};

/// Scanner mountings of the simulated car.
SimScannerOptions simFrontScanner();
SimScannerOptions simBackScanner();

/// Bearing of beam i of a simulated scanner, in its own frame.
double simBeamAngle(const SimScannerOptions& scanner, std::size_t i);

/// Drives the route through `world`; throws std::invalid_argument on bad options.
SimDrive simulateDrive(const SimWorld& world, const SimDriveOptions& options);

/// World options that cover a drive of these options (size grows with the length).
WorldOptions simWorldOptions(const SimDriveOptions& options);

}  // namespace llc
