// Writes a simulated drive as a CARMEN log that readCarmenLog reads back.
#pragma once

#include <string>

#include "laser_loop_closure/core/sim/sim_drive.hpp"

namespace llc {

/// PARAM lines for the laser offsets, then per frame: ODOM, FLASER, TRUEPOS (the true pose of
/// the FLASER scan), RLASER. No-return beams are written as the scanner's maximum range.
/// Fixed decimals, so one drive always gives the same bytes. Throws std::runtime_error when the
/// file cannot be written.
void writeCarmenLog(const SimDrive& drive, const std::string& path);

}  // namespace llc
