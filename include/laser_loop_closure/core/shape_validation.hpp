// Shape validation of an alignment (the paper, section VI): after alignment, enough of the
// nearest-neighbour point pairs must lie close together, or the loop is refused.
#pragma once

#include <string>

#include "laser_loop_closure/core/point_cloud.hpp"

namespace llc {

struct ShapeValidationOptions {
  double max_distance = 1.0;      ///< m (the paper's d); a pair farther apart is an outlier
  double min_inlier_share = 0.9;  ///< (the paper's N); accepted when at least this share is within d
  /// Count only the source points that the target's scanner could have seen (inside its field
  /// of view and range); the paper's 360-degree scans see everything, a 180-degree scanner
  /// turned by 45 degrees does not, and its unseen points are no evidence against the match.
  bool only_in_view = true;
  std::string validate() const;
};

/// What a scan's scanner could see, in the scan's own frame: bearings [min, max] from its
/// origin (everything when full_circle) up to max_range.
struct FieldOfView {
  bool full_circle = true;
  double bearing_min = -M_PI, bearing_max = M_PI;  ///< rad
  double max_range = 1e9;                          ///< m
  bool contains(const Point2& p) const;
};
/// The field of view of a scan: its bearing span (full circle when marked so) and max_range.
FieldOfView fieldOfView(const Scan& scan, double max_range);

struct ShapeValidationResult {
  bool accepted = false;
  double inlier_share = 0.0;  ///< share of source points whose nearest target point is within d
  std::size_t points = 0;     ///< source points tested
  std::string reject_reason;  ///< empty when accepted
};

/// Moves every source point by `pose` (source frame in target frame) and pairs it with its
/// nearest target point; with options.only_in_view and a target_view, source points outside
/// the target's view are left out (points then counts only those inside).
ShapeValidationResult validateShape(const Points2& source, const KdTree2& target, const Pose2& pose,
                                    const ShapeValidationOptions& options, const FieldOfView* target_view = nullptr);

}  // namespace llc
