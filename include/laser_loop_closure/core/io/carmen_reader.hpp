// Reader for CARMEN log files (plain or gzip): FLASER, RLASER, ROBOTLASER1, ODOM, TRUEPOS.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

#include "laser_loop_closure/core/geometry/scan.hpp"
#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc {

/// One laser line: ranges in the scanner's own frame, its geometry and the poses on the line.
struct CarmenLaser {
  std::vector<double> ranges;  ///< metres, as written (no-return beams hold the maximum)
  ScannerGeometry geometry;
  Pose2 pose;           ///< FLASER/RLASER x y theta; ROBOTLASER1 laser pose
  Pose2 odometry;       ///< FLASER/RLASER odom_x ...; ROBOTLASER1 robot pose
  double stamp = 0.0;   ///< ipc timestamp, seconds
  std::size_t line = 0; ///< 1-based line number in the file
};

struct CarmenOdometry {
  Pose2 pose;
  double stamp = 0.0;
};

struct CarmenTruePose {
  Pose2 truth;
  Pose2 odometry;
  double stamp = 0.0;
  std::size_t line = 0;
};

struct CarmenLog {
  std::string path;
  std::vector<CarmenLaser> front;  ///< FLASER and ROBOTLASER1 lines, in file order
  std::vector<CarmenLaser> rear;   ///< RLASER lines, in file order
  std::vector<CarmenOdometry> odometry;
  std::vector<CarmenTruePose> truth;
  /// For each front scan, the index into `truth` of the TRUEPOS line that follows it before
  /// the next front scan, or -1.
  std::vector<long> front_truth;
  double front_laser_offset = 0.0;  ///< m along the robot's x (PARAM robot_frontlaser_offset)
  double rear_laser_offset = 0.0;   ///< m along the robot's x (PARAM robot_rearlaser_offset)
};

/// A malformed line or an unreadable file; what() says "FILE:LINE: problem".
class CarmenError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Reads a whole log. Comments (#) and other line types (PARAM other than the laser offsets,
/// NEFF, SYNC, VERTEX2, EDGE2, ...) are skipped; a malformed line of a known type throws.
CarmenLog readCarmenLog(const std::string& path);

}  // namespace llc
