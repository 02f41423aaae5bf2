// A bounded correlative search (Olson 2009, as Karto and Cartographer seed their matchers):
// every pose of a window around a centre is scored by how close the moved source points fall
// to the target's points, read from a likelihood field made once. Unlike ICP it cannot slide
// into the nearest minimum, so it finds the motion where the guess is far off (wheels that
// count a reverse as forward, a long gap between scans); unlike the global search it needs a
// window. Its pose is a start for ICP; its score also says how well any pose fits.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "laser_loop_closure/core/geometry/point_cloud.hpp"

namespace llc {

struct CorrelativeSearchOptions {
  double cell = 0.05;              ///< m; cell of the likelihood field
  double sigma = 0.05;             ///< m; a point this far from the nearest target point scores exp(-1/2)
  double max_range = 20.0;         ///< m; target points farther from the scanner are left out of the field
  /// m; consecutive target points this near, their segment not along the beam, are joined by a
  /// line: a wall seen at a grazing angle is a wall, not a row of dots that favours one shift
  /// along it (0: points only)
  double connect_distance = 1.0;
  double max_translation = 0.5;    ///< m; translations searched within this of the centre, on each axis
  double translation_step = 0.1;   ///< m; between searched translations (a multiple of cell is exact)
  double max_rotation = 0.35;      ///< rad; rotations searched within this of the centre's
  double rotation_step = 0.02;     ///< rad; between searched rotations
  std::size_t max_points = 180;    ///< source points scored, evenly strided (0: all)
  [[nodiscard]] std::string validate() const;
};

struct CorrelativeSearchResult {
  bool found = false;
  Pose2 pose;                 ///< the best pose of the window (source in the target's frame)
  double score = 0.0;         ///< its correlativeScore
  std::size_t poses_scored = 0;
  double seconds = 0.0;
  std::string reject_reason;  ///< why there is none (no source points, empty field)
};

/// exp(-d^2 / 2 sigma^2), d the distance to the nearest target point or joined segment
/// (connect_distance), on a grid over the target's points within max_range (and 3 sigma
/// around them); 0 outside it. Target points in beam order, from a scanner at the origin.
class LikelihoodField {
 public:
  LikelihoodField(const Points2& target, const CorrelativeSearchOptions& options);
  double at(double x, double y) const;
  bool empty() const { return width_ == 0; }

 private:
  friend CorrelativeSearchResult searchCorrelative(const LikelihoodField&, const Points2&, const Pose2&,
                                                   const CorrelativeSearchOptions&);
  double cell_ = 0.05, min_x_ = 0.0, min_y_ = 0.0;
  int width_ = 0, height_ = 0;
  std::vector<float> values_;
};

/// Whether `pose` lies within the search window around `centre` (max_translation on each axis,
/// max_rotation), widened by `margin_steps` of translation_step and rotation_step.
bool withinWindow(const CorrelativeSearchOptions& window, const Pose2& pose, const Pose2& centre, double margin_steps = 0.0);

/// Mean field value over the source points (strided to max_points) moved by pose: 1 when every
/// point lies on a target point, 0 when none is within a few sigma.
double correlativeScore(const LikelihoodField& field, const Points2& source, const Pose2& pose, std::size_t max_points);

/// How far the source can be moved from `pose` along the unit vector `direction` (either way,
/// in steps of `step`, up to `max_shift`) while its correlativeScore stays within `max_drop`
/// of the score at `pose`: the longer of the two sides, in m (0 when the first step already
/// falls further, or for no source points, an empty field or a pose that is not finite).
/// Along a corridor, where the scans cannot tell where the robot is, it is long.
double ambiguousShift(const LikelihoodField& field, const Points2& source, const Pose2& pose, const Point2& direction,
                      double max_shift, double step, double max_drop, std::size_t max_points);

/// The best pose within the window around centre (ties: the one nearest the centre).
CorrelativeSearchResult searchCorrelative(const LikelihoodField& field, const Points2& source, const Pose2& centre,
                                          const CorrelativeSearchOptions& options);

}  // namespace llc
