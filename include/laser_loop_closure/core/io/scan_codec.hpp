// A scan packed small for a network (a robot's keyframes to a shared back end). A merged scan's
// beams come from scanners mounted away from the base origin, so their base-frame bearings do
// not step evenly; seen from their scanner they do. The packing finds those origins (runs of
// returns whose directions step evenly from one point), and writes each beam from the origin
// whose codes cost least (of those it steps evenly from, if any): its direction in bearing_step
// steps (second difference from that source's previous beam) and its range from there in
// range_step steps, less what that source's last ranges predict; all of it through an adaptive
// range coder (range_coder.hpp, LSC4; LSC3 of version 0.20 is read too). Each point comes back within about half a range step and
// half a bearing step (times its range from its origin) of where it was; bearings and ranges
// are computed again from the point, beams in increasing bearing. A range that is not finite,
// not positive or beyond what the format holds is "no return" (+inf, REP-117) along its ray.
// The stamp is not in it (the message header has it). With a beam_stride above 1 only every
// beam_stride-th beam is written: a thinner scan.
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
  std::size_t beam_stride = 1;   ///< write beams 0, n, 2n, ... (1: every beam); bytes fall about as 1/n
  [[nodiscard]] std::string validate() const;
};

/// The packed scan. Throws std::invalid_argument on bad options, ranges and bearings of
/// different lengths, or a bearing that is not finite.
std::vector<std::uint8_t> packScan(const Scan& scan, const ScanPackOptions& options = {});

/// Reads a packed scan (LSC4, or LSC3) into `scan` (stamp left as it was); false with `error` on
/// anything that is not one (truncated, corrupt, too many beams). Never throws on bad data.
bool unpackScan(const std::vector<std::uint8_t>& packed, Scan* scan, std::string* error);

}  // namespace llc
