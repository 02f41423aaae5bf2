// The occupancy grid of a map that keeps changing: keyframes are drawn once and taken out again
// when their pose moves, so that an update costs what changed, not the size of the map.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <unordered_map>
#include <vector>

#include "laser_loop_closure/core/io/compact_scan.hpp"
#include "laser_loop_closure/core/map/occupancy_grid.hpp"

namespace llc {

/// Cells [col, col + cols) x [row, row + rows), counted from the map frame's origin (cell (0, 0)
/// has its corner at x = y = 0).
struct CellBox {
  long col = 0, row = 0, cols = 0, rows = 0;
  bool empty() const { return cols <= 0 || rows <= 0; }
  double cells() const { return double(cols) * double(rows); }
};

/// What one update did.
struct GridUpdateResult {
  std::size_t drawn = 0;     ///< keyframes drawn for the first time
  std::size_t redrawn = 0;   ///< keyframes taken out at their old pose and drawn at the new one
  std::size_t removed = 0;   ///< keyframes taken out because they are no longer given
  std::size_t waiting = 0;   ///< keyframes new or moved but left for the next update (max_draws)
  std::size_t refused = 0;   ///< keyframes not drawn: their pose is not finite
  std::size_t too_large = 0; ///< keyframes not drawn: they would take the grid over max_cells
  bool bounds_grew = false;  ///< bounds() changed: send the whole grid
  std::vector<CellBox> changed;  ///< within bounds(): rows of tiles whose cells changed (send these)
};

class IncrementalOccupancyGrid {
 public:
  static constexpr int kTileCells = 64;  ///< cells per side of a tile (memory is held per observed tile)

  /// Throws std::invalid_argument on bad options.
  explicit IncrementalOccupancyGrid(const OccupancyGridOptions& options);
  ~IncrementalOccupancyGrid();
  IncrementalOccupancyGrid(IncrementalOccupancyGrid&&) noexcept;
  IncrementalOccupancyGrid& operator=(IncrementalOccupancyGrid&&) noexcept;

  /// Brings the grid to scans[k] seen at poses[k]: keyframes not drawn yet, moved beyond
  /// redraw_distance / redraw_angle, or given another scan are (re)drawn, max_draws of them at
  /// most (new first, then the most moved); keyframes beyond scans.size() are taken out. A null
  /// scan is skipped. Throws std::invalid_argument when the sizes differ.
  GridUpdateResult update(const std::vector<std::shared_ptr<const CompactScan>>& scans, const std::vector<Pose2>& poses,
                          std::size_t max_draws = std::numeric_limits<std::size_t>::max());

  /// Everything observed, with the margin, grown in steps of grow_step (empty before any keyframe).
  CellBox bounds() const { return bounds_; }
  /// The cells of `box` (bounds() for the whole grid): -1 unknown, else percent occupied.
  OccupancyGrid region(const CellBox& box) const;
  /// Tiles allocated (each holds kTileCells^2 cells).
  std::size_t tiles() const { return tiles_.size(); }
  /// Bytes held: tiles and the record of what was drawn where (scans are shared, not counted).
  std::size_t bytes() const;
  /// Keyframes drawn and where.
  std::size_t drawnKeyframes() const;

 private:
  struct Tile;
  struct Drawn {
    std::shared_ptr<const CompactScan> scan;  ///< null: not on the grid
    Pose2 pose;
  };
  void draw(const Scan& scan, const Pose2& pose, int sign);
  std::int16_t* cellFor(long col, long row);
  void add(long col, long row, std::int32_t delta);
  bool fits(const Pose2& pose) const;
  void growBounds(const CellBox& needed, double step_cells, GridUpdateResult* result);

  OccupancyGridOptions options_;
  std::int32_t hit_ = 0, miss_ = 0, clamp_ = 0;  ///< log-odds in steps of 0.01
  std::vector<std::int8_t> percent_;               ///< percent occupied for a clamped sum, from -clamp_
  std::unordered_map<std::uint64_t, std::unique_ptr<Tile>> tiles_;
  std::vector<std::uint64_t> touched_;  ///< tiles changed in the current update
  std::uint32_t epoch_ = 1;             ///< the current update's number (a tile touched in it holds it)
  std::uint64_t last_key_ = 0;  ///< the tile of the last cell (most steps of a ray stay in it)
  Tile* last_tile_ = nullptr;   ///< set only after its epoch was checked in this update
  std::vector<Drawn> drawn_;
  CellBox observed_;  ///< every pose and beam end drawn so far
  CellBox bounds_;
};

}  // namespace llc
