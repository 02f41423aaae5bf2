// The simulated city: static surfaces (facades, fences, hedges, poles, trees), parked cars that
// come and go, and moving cars and pedestrians; ray casting against all of it at a given time.
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

namespace llc {

struct WorldPoint {
  double x = 0.0, y = 0.0;
};

/// A surface that exists during [appear, vanish) seconds (forever by default).
struct WorldSegment {
  WorldPoint a, b;
  double appear = -std::numeric_limits<double>::infinity();
  double vanish = std::numeric_limits<double>::infinity();
};
struct WorldCircle {
  WorldPoint centre;
  double radius = 0.1;
};

/// Something that moves along a straight line at constant speed during [start, stop).
struct WorldMover {
  WorldPoint origin;       ///< where it is at `start`
  double heading = 0.0;    ///< rad, direction of travel
  double speed = 0.0;      ///< m/s
  double start = 0.0, stop = 0.0;
  double length = 0.4, width = 0.4;  ///< m; a box (car) or, when equal and small, a pedestrian
};

struct WorldOptions {
  int blocks_x = 7;            ///< city blocks along x
  int blocks_y = 7;            ///< city blocks along y
  double block_pitch = 100.0;  ///< m between street centre lines
  double street_width = 20.0;  ///< m from facade line to facade line minus sidewalks
  double duration = 600.0;     ///< s the world must cover (parked-car turnover, movers)
  /// s; mean time a parking slot stays occupied (or free). Short-stay city-centre parking:
  /// a street revisited minutes later has some of its cars changed, not all of them.
  double parking_mean_s = 1800.0;
  std::uint64_t seed = 1;
};

/// Kinds of block, for the picture and for tests.
enum class BlockKind : std::uint8_t { kBuildings, kPark, kCarPark, kSquare };

class SimWorld {
 public:
  /// Builds a random city for the options (deterministic for a seed).
  explicit SimWorld(const WorldOptions& options);

  const WorldOptions& options() const { return options_; }
  const std::vector<WorldSegment>& segments() const { return segments_; }
  const std::vector<WorldCircle>& circles() const { return circles_; }
  const std::vector<WorldMover>& movers() const { return movers_; }
  BlockKind block(int i, int j) const { return blocks_[std::size_t(j * options_.blocks_x + i)]; }
  /// Street-grid node (i, j), 0 <= i <= blocks_x: the centre of that intersection.
  WorldPoint node(int i, int j) const { return {i * options_.block_pitch, j * options_.block_pitch}; }

  /// Distance along the ray from (x, y) in direction `angle` to the first surface present at
  /// `time` (and of `extra`, e.g. moverOutlines), or +inf when there is none within max_range.
  double castRay(double x, double y, double angle, double time, double max_range,
                 const std::vector<WorldSegment>* extra = nullptr) const;

  /// Outlines of the movers present at `time` within `range` of (x, y). A mover whose box, grown
  /// by `ego_half_width`, holds one of the `ego` points (the ego vehicle's axis: its base and
  /// scanners) would be driving through the ego vehicle; it is left out meanwhile, as if it had
  /// gone round (movers keep lane and speed; the ego is no obstacle to them).
  std::vector<WorldSegment> moverOutlines(double time, double x, double y, double range,
                                          const std::vector<WorldPoint>& ego = {}, double ego_half_width = 0.0) const;

  /// Distance from (x, y) to the nearest surface present at `time` (for tests: scan points lie
  /// on surfaces). Brute force.
  double distanceToSurface(double x, double y, double time, const std::vector<WorldSegment>* extra = nullptr) const;

 private:
  void addSegment(WorldPoint a, WorldPoint b, double appear = -kForever, double vanish = kForever);
  void addPolyline(const std::vector<WorldPoint>& points);
  void buildGrid();
  static constexpr double kForever = std::numeric_limits<double>::infinity();

  WorldOptions options_;
  std::vector<BlockKind> blocks_;
  std::vector<WorldSegment> segments_;
  std::vector<WorldCircle> circles_;
  std::vector<WorldMover> movers_;
  // Uniform grid over the world: per cell, indices of segments (>= 0) and circles (~index).
  double cell_ = 4.0, min_x_ = 0.0, min_y_ = 0.0;
  int cols_ = 0, rows_ = 0;
  std::vector<std::uint32_t> cell_start_;
  std::vector<std::int32_t> cell_items_;
};

}  // namespace llc
