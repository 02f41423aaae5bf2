// Shape validation of an alignment (the paper, section VI): after alignment, enough of the
// nearest-neighbour point pairs must lie close together, or the loop is refused.
#pragma once

#include <string>
#include <vector>

#include "laser_loop_closure/core/geometry/point_cloud.hpp"

namespace llc {

struct ShapeValidationOptions {
  double max_distance = 1.0;      ///< m (the paper's d); a pair farther apart is an outlier
  double min_inlier_share = 0.9;  ///< (the paper's N); accepted when at least this share is within d
  /// Count only the source points that the target's scanner could have seen (inside its field
  /// of view and range); the paper's 360-degree scans see everything, a 180-degree scanner
  /// turned by 45 degrees does not, and its unseen points are no evidence against the match.
  bool only_in_view = true;
  /// Beyond the paper: a point of one scan that lies where the other scanner saw through it
  /// (every nearby beam returned from more than free_space_margin beyond it) contradicts the
  /// alignment. Refused when, either way round, more than this share of the points tested
  /// does (1 = the check is off, as in the paper).
  double max_seen_through_share = 0.1;
  double free_space_margin = 0.5;  ///< m
  /// Beyond the paper: refused when ICP leaves the position this uncertain along its weakest
  /// direction (m, the square root of the largest eigenvalue of its x-y covariance): a long
  /// corridor fits anywhere along it, and two stretches of one look alike (0 = the check is off).
  /// The covariance scales with the residuals and the pairs ICP uses (icp.max_source_points).
  double max_position_std = 0.015;
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

/// Where a scan's beams ended, by bearing (normalised, sorted), for the seen-through test:
/// range of a return nearer than max_range, NaN where the beam gives no evidence.
struct FreeSpace {
  std::vector<double> bearings, ranges;
  bool full_circle = false;
  bool empty() const { return bearings.empty(); }
};
FreeSpace freeSpace(const Scan& scan, double max_range);

/// The share of source points (moved by pose into the target's frame) that the target's
/// scanner saw through by more than margin: the beams bracketing the point's bearing and one
/// more on each side all returned farther than its range + margin (at least one returned).
/// Points outside the beams' span, or with no returning beam near, are not tested; *tested
/// counts the others. 0 when none is tested.
double seenThroughShare(const Points2& source, const Pose2& pose, const FreeSpace& target, double margin,
                        std::size_t* tested = nullptr);

struct ShapeValidationResult {
  bool accepted = false;
  double inlier_share = 0.0;  ///< share of source points whose nearest target point is within d
  double seen_through_share = 0.0;  ///< the larger of the two ways round (when the check ran)
  double position_std = 0.0;        ///< m, of the ICP result along its weakest direction (when the check ran)
  std::size_t points = 0;     ///< source points tested
  std::string reject_reason;  ///< empty when accepted
};

/// Moves every source point by `pose` (source frame in target frame) and pairs it with its
/// nearest target point; with options.only_in_view and a target_view, source points outside
/// the target's view are left out (points then counts only those inside).
ShapeValidationResult validateShape(const Points2& source, const KdTree2& target, const Pose2& pose,
                                    const ShapeValidationOptions& options, const FieldOfView* target_view = nullptr);

}  // namespace llc
