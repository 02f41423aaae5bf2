// A picture of a SLAM result: the occupancy grid, the trajectory and the loops (applied in
// green, applied by a consensus of loops the gate had refused in orange, refused in red), for
// people to look at (map.png of `llc slam`).
#pragma once

#include <string>
#include <vector>

#include "laser_loop_closure/core/map/occupancy_grid.hpp"
#include "laser_loop_closure/core/common/png_image.hpp"

namespace llc {

struct PictureLoop {
  std::size_t from = 0, to = 0;  ///< indices into the trajectory
  bool applied = false;
  bool by_consensus = false;  ///< applied by LoopConsensus after the gate refused it
};

/// Renders the grid at most max_pixels wide and high (cells are pooled, occupied wins), and a
/// small grid magnified by a whole factor towards min_pixels, with the trajectory in blue and
/// the loops as lines between their poses: refused ones faint (there are often hundreds of
/// them), applied ones on top.
RgbImage renderMapPicture(const OccupancyGrid& grid, const std::vector<Pose2>& trajectory,
                          const std::vector<PictureLoop>& loops, int max_pixels = 2000, int min_pixels = 1000);

}  // namespace llc
