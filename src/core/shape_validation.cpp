#include "laser_loop_closure/core/shape_validation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace llc {

std::string ShapeValidationOptions::validate() const {
  if (!(max_distance > 0.0)) return "max_distance must be > 0";
  if (!(min_inlier_share >= 0.0 && min_inlier_share <= 1.0)) return "min_inlier_share must be in [0, 1]";
  return "";
}

bool FieldOfView::contains(const Point2& p) const {
  if (!(p.squaredNorm() < max_range * max_range)) return false;
  if (full_circle) return true;
  const double bearing = std::atan2(p.y(), p.x());
  return bearing >= bearing_min && bearing <= bearing_max;
}

FieldOfView fieldOfView(const Scan& scan, double max_range) {
  FieldOfView view;
  view.max_range = max_range;
  view.full_circle = scan.full_circle;
  if (view.full_circle) return view;
  double lo = M_PI, hi = -M_PI;
  for (double b : scan.bearings)
    if (std::isfinite(b)) lo = std::min(lo, normalizeAngle(b)), hi = std::max(hi, normalizeAngle(b));
  if (lo > hi) lo = hi = 0.0;  // no usable bearing: sees nothing but straight ahead
  view.bearing_min = lo;
  view.bearing_max = hi;
  return view;
}

ShapeValidationResult validateShape(const Points2& source, const KdTree2& target, const Pose2& pose,
                                    const ShapeValidationOptions& options, const FieldOfView* target_view) {
  ShapeValidationResult result;
  if (source.empty() || target.size() == 0) {
    result.reject_reason = "no points to compare";
    return result;
  }
  const double limit_sq = options.max_distance * options.max_distance;
  std::size_t inliers = 0, tested = 0;
  const RigidMotion2 motion(pose);
  const bool filter = options.only_in_view && target_view;
  for (const Point2& p : source) {
    const Point2 moved = motion(p);
    if (filter && !target_view->contains(moved)) continue;
    ++tested;
    std::size_t index;
    double distance_sq;
    if (target.nearest(moved, &index, &distance_sq, limit_sq) && distance_sq <= limit_sq) ++inliers;
  }
  result.points = tested;
  if (tested == 0) {
    result.reject_reason = "no point in the other scan's view";
    return result;
  }
  result.inlier_share = double(inliers) / double(tested);
  result.accepted = result.inlier_share >= options.min_inlier_share;
  if (!result.accepted) {
    char text[96];
    std::snprintf(text, sizeof text, "inlier share %.3f below %.3f", result.inlier_share, options.min_inlier_share);
    result.reject_reason = text;
  }
  return result;
}

}  // namespace llc
