// An occupancy grid of keyframe scans at their (optimised) poses, by ray casting with
// log-odds (drawn by IncrementalOccupancyGrid), and the map_server file format (PGM + YAML).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "laser_loop_closure/core/io/compact_scan.hpp"
#include "laser_loop_closure/core/geometry/scan.hpp"
#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc {

struct OccupancyGridOptions {
  double resolution = 0.1;       ///< m per cell
  double max_range = 30.0;       ///< m; returns at or beyond are not drawn (taken as no return)
  /// m; a beam with no return (+inf, REP-117) marks free space up to this range; 0: nothing
  /// (a window or a black surface would otherwise carve free space through a wall)
  double no_return_free_range = 0.0;
  double hit_log_odds = 0.85;    ///< added to the cell a beam ends in
  double miss_log_odds = -0.4;   ///< added to every cell a beam crosses
  /// |log-odds| shown never exceeds this. The sum itself is kept unclamped (in steps of 0.01, up
  /// to +-327), so that a keyframe drawn once can be taken out exactly when its pose moves.
  double clamp_log_odds = 5.0;
  double occupied_threshold = 0.65;  ///< probability above which a cell is occupied (map_server's occupied_thresh)
  double free_threshold = 0.196;     ///< below which it is free (map_server's free_thresh)
  double margin = 2.0;           ///< m of unknown border around everything observed
  std::size_t max_cells = 200000000;  ///< refuse a grid larger than this (memory), instead of swapping
  // The back ends' /map, kept up to date by IncrementalOccupancyGrid:
  double redraw_distance = 0.05;  ///< m; a keyframe whose pose moved further since it was drawn is drawn again
  double redraw_angle = 0.005;    ///< rad; or whose heading turned further (0.15 m at 30 m)
  /// keyframes drawn or redrawn per /map update at most (new ones first, then the most moved):
  /// an update costs the same on a large map (~0.8 ms per keyframe moved); the rest wait for
  /// the next update, which then comes as soon as map_cpu_share allows
  int max_draws_per_update = 50;
  /// m; when the map outgrows its bounds, the sides too short grow this much further, or a
  /// quarter of the map's size when that is more (a whole /map is sent then)
  double grow_step = 20.0;
  [[nodiscard]] std::string validate() const;
};

/// Row-major, row 0 at origin_y (the bottom, as in nav_msgs/OccupancyGrid): -1 unknown, else
/// the occupancy probability in percent (0 free .. 100 occupied).
struct OccupancyGrid {
  double resolution = 0.1;
  double origin_x = 0.0, origin_y = 0.0;  ///< m, the corner of cell (0, 0)
  int width = 0, height = 0;
  std::vector<std::int8_t> cells;
  std::int8_t at(int col, int row) const { return cells[std::size_t(row) * std::size_t(width) + std::size_t(col)]; }
};

/// Builds the grid from scans[i] seen at poses[i] (base frame in map frame): every keyframe
/// drawn into an IncrementalOccupancyGrid, its bounds everything observed plus the margin.
/// Throws std::invalid_argument on bad options, mismatched sizes, or a grid above max_cells.
OccupancyGrid buildOccupancyGrid(const std::vector<const Scan*>& scans, const std::vector<Pose2>& poses,
                                 const OccupancyGridOptions& options = {});
/// The same from scans kept compact (a null scan is left out).
OccupancyGrid buildOccupancyGrid(const std::vector<std::shared_ptr<const CompactScan>>& scans,
                                 const std::vector<Pose2>& poses, const OccupancyGridOptions& options = {});

/// Writes `stem`.pgm and `stem`.yaml as map_server reads them (254 free, 0 occupied, 205
/// unknown; top image row = largest y). Each file goes to a temporary name and is renamed.
/// Throws std::runtime_error when it cannot write.
void saveMapFiles(const OccupancyGrid& grid, const std::string& stem, const OccupancyGridOptions& options = {});

/// Reads what saveMapFiles wrote (trinary: 0, 100 or -1 per cell). Throws std::runtime_error
/// naming the file on anything malformed or truncated.
OccupancyGrid loadMapFiles(const std::string& yaml_path);

}  // namespace llc
