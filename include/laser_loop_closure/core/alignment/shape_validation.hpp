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
  [[nodiscard]] std::string validate() const;
};

/// What a scan's scanner could see, in the scan's own frame: bearings [min, max] from its
/// origin (everything for a full circle) up to max_range.
class FieldOfView {
 public:
  FieldOfView() = default;  ///< the full circle to 1e9 m
  static FieldOfView fullCircle(double max_range);
  /// Bearings [bearing_min, bearing_max] (rad, -pi <= min <= max <= pi) up to max_range (m).
  static FieldOfView arc(double bearing_min, double bearing_max, double max_range);
  bool fullCircle() const { return full_circle_; }
  double maxRange() const { return max_range_; }
  /// rad: 2 pi for the full circle, else the arc's span.
  double width() const { return width_; }
  /// Within range and (unless a full circle) between the two edge bearings. ICP asks this
  /// of every source point in every pairing round: two cross products, no atan2.
  bool contains(const Point2& p) const {
    if (!(p.squaredNorm() < max_range_ * max_range_)) return false;
    if (full_circle_) return true;
    const bool after_min = edge_min_.x() * p.y() - edge_min_.y() * p.x() >= 0.0;
    const bool before_max = p.x() * edge_max_.y() - p.y() * edge_max_.x() >= 0.0;
    if (wide_) return after_min || before_max;
    // (Not on the far side: an arc of zero width would otherwise hold its backward ray too.)
    return after_min && before_max && p.dot(edge_min_ + edge_max_) >= 0.0;
  }

 private:
  bool full_circle_ = true;
  double max_range_ = 1e9;
  Point2 edge_min_{-1.0, 0.0}, edge_max_{-1.0, 0.0};  ///< unit vectors at the edge bearings
  bool wide_ = false;  ///< the arc spans more than pi: outside only between max and min
  double width_ = 2.0 * M_PI;
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
