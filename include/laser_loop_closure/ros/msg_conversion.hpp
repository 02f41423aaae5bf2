// Conversions between ROS messages and core types: free functions, no state.
#pragma once

#include <sensor_msgs/LaserScan.h>

#include <string>

#include "laser_loop_closure/Scan360.h"
#include "laser_loop_closure/core/scan.hpp"
#include "laser_loop_closure/core/se2.hpp"

namespace llc_ros {

/// A LaserScan as a core scan in the base frame, the scanner mounted at `mount`. Per REP-117,
/// readings above range_max become +inf and readings below range_min -inf (no return / too
/// close); NaN stays NaN. Returns false with a reason for a message that cannot be a scan
/// (non-finite or zero angle increment, angle span disagreeing with the beam count).
bool toScan(const sensor_msgs::LaserScan& msg, const llc::Pose2& mount, llc::Scan* scan,
            std::string* error);

laser_loop_closure::Scan360 toScan360(const llc::Scan& scan, const std_msgs::Header& header);
/// False with a reason when ranges and bearings differ in length.
bool fromScan360(const laser_loop_closure::Scan360& msg, llc::Scan* scan, std::string* error);

}  // namespace llc_ros
