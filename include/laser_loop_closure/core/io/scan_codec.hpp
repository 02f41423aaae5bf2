// A scan packed small for a network (a robot's keyframes to a shared back end): each bearing
// and range rounded to a fixed step (bearing_step rad, range_step m), written as the difference
// from the one before (zigzag varints), and the whole deflated by zlib. Lossless up to those
// steps; a range that is not finite, not positive or beyond what the format holds is "no
// return" (+inf, REP-117). The stamp is not in it (the message header has it).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "laser_loop_closure/core/geometry/scan.hpp"

namespace llc {

struct ScanPackOptions {
  double range_step = 0.005;     ///< m (a laser's noise is about 1 cm); ranges up to 2^31 steps
  double bearing_step = 1.0e-4;  ///< rad (1 mm across at 10 m)
  [[nodiscard]] std::string validate() const;
};

/// The packed scan. Throws std::invalid_argument on bad options, ranges and bearings of
/// different lengths, or a bearing that is not finite.
std::vector<std::uint8_t> packScan(const Scan& scan, const ScanPackOptions& options = {});

/// Reads a packed scan into `scan` (stamp left as it was); false with `error` on anything that
/// is not one (truncated, corrupt, too many beams). Never throws on bad data.
bool unpackScan(const std::vector<std::uint8_t>& packed, Scan* scan, std::string* error);

}  // namespace llc
