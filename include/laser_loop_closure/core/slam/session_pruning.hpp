// A saved map at bounded size (issue 66): where several keyframes see the same place from the
// same side, the oldest are kept and the others retired, their constraints marginalised into
// the keyframes that stay (backend/marginalization.hpp), so the map keeps what they told the
// graph. A place is a square cell of the map frame and a sector of heading: a street driven
// both ways keeps a keyframe for each way, which the classifier needs to recognise it from
// either side. The oldest are kept because they are the ones the map has placed best (a new
// day's keyframes only add loops to them); keeping the newest instead (the world as it looks
// now) let the map's RMS grow tenfold on one simulated city (docs/lifelong.md).
#pragma once

#include <cstddef>
#include <string>

#include "laser_loop_closure/core/slam/slam_types.hpp"

namespace llc {

struct SessionPruningOptions {
  double place_size = 2.0;          ///< m; side of the square cells of the map frame a place is
  std::size_t heading_sectors = 4;  ///< sectors of heading per place, each keeping its own keyframes
  std::size_t keep_per_place = 1;   ///< keyframes kept per place and heading sector; 0: no pruning
  bool keep_newest = false;         ///< keep a place's newest keyframes instead of its oldest (see above)
  [[nodiscard]] std::string validate() const;
};

struct SessionPruningResult {
  std::size_t keyframes_before = 0, keyframes_after = 0;
  std::size_t constraints_before = 0, constraints_after = 0;
  std::size_t places = 0;              ///< places and heading sectors with a keyframe (keyframe 0's included)
  std::size_t loops_dropped = 0;       ///< loop records that named a retired keyframe
  std::size_t kept_unfactorizable = 0; ///< to retire, but kept (PoseGraphReduction)
  double mean_kl = 0.0, max_kl = 0.0;  ///< nats per retired keyframe: what sparsifying lost
  double seconds = 0.0;
};

/// The session with the keyframes beyond keep_per_place in each place (the oldest, or with
/// keep_newest false the newest) retired (keyframe 0,
/// the map's anchor, always stays): their scans, features and loop records dropped, their
/// constraints marginalised into the others, everything renumbered. Throws
/// std::invalid_argument on bad options or a session that does not validate().
SlamSession pruneSession(const SlamSession& session, const SessionPruningOptions& options, SessionPruningResult* result);

}  // namespace llc
