// A picture of a SLAM result: the occupancy grid, the trajectory and the loops (applied in
// green, refused in red), for people to look at (map.png of `llc slam`).
#pragma once

#include <string>
#include <vector>

#include "laser_loop_closure/core/occupancy_grid.hpp"
#include "laser_loop_closure/core/png_image.hpp"

namespace llc {

struct PictureLoop {
  std::size_t from = 0, to = 0;  ///< indices into the trajectory
  bool applied = false;
};

/// Renders the grid at most max_pixels wide and high (cells are pooled, occupied wins), with
/// the trajectory in blue and the loops as lines between their poses.
RgbImage renderMapPicture(const OccupancyGrid& grid, const std::vector<Pose2>& trajectory,
                          const std::vector<PictureLoop>& loops, int max_pixels = 2000);

}  // namespace llc
