// Shape validation of an alignment (the paper, section VI): after alignment, enough of the
// nearest-neighbour point pairs must lie close together, or the loop is refused.
#pragma once

#include <string>

#include "laser_loop_closure/core/point_cloud.hpp"

namespace llc {

struct ShapeValidationOptions {
  double max_distance = 1.0;      ///< m (the paper's d); a pair farther apart is an outlier
  double min_inlier_share = 0.9;  ///< (the paper's N); accepted when at least this share is within d
  std::string validate() const;
};

struct ShapeValidationResult {
  bool accepted = false;
  double inlier_share = 0.0;  ///< share of source points whose nearest target point is within d
  std::size_t points = 0;     ///< source points tested
  std::string reject_reason;  ///< empty when accepted
};

/// Moves every source point by `pose` (source frame in target frame) and pairs it with its
/// nearest target point.
ShapeValidationResult validateShape(const Points2& source, const KdTree2& target, const Pose2& pose,
                                    const ShapeValidationOptions& options);

}  // namespace llc
