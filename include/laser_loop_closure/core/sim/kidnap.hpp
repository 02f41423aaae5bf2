// A kidnapped robot made from any recording: it is carried from one place of the drive to
// another while its odometry runs on as if it had not moved. What a localiser must notice
// (its scans stop fitting the map where it thinks it is) and recover from.
#pragma once

#include <cstddef>

#include "laser_loop_closure/core/io/scan_sequence.hpp"
#include "laser_loop_closure/core/sim/sim_drive.hpp"

namespace llc {

/// Scans 0 .. at-1 of `input`, then its scans from `to` on, as if the robot were carried from
/// where scan at-1 was taken to where scan `to` was: their truth is theirs, their odometry and
/// stamps go on from scan at-1 by the recorded steps from scan to-1 (no jump in either).
/// Throws std::invalid_argument unless 0 < at < input size and 0 < to < input size.
ScanSequence kidnapped(const ScanSequence& input, std::size_t at, std::size_t to);
/// The same for a simulated drive (`llc simulate --kidnap-at/--kidnap-to`): frame truths are
/// theirs, odometry and stamps go on without a jump.
SimDrive kidnapped(const SimDrive& drive, std::size_t at, std::size_t to);

}  // namespace llc
