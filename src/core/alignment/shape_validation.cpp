#include "laser_loop_closure/core/alignment/shape_validation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace llc {

std::string ShapeValidationOptions::validate() const {
  if (!(max_distance > 0.0)) return "max_distance must be > 0";
  if (!(min_inlier_share >= 0.0 && min_inlier_share <= 1.0)) return "min_inlier_share must be in [0, 1]";
  if (!(max_seen_through_share >= 0.0 && max_seen_through_share <= 1.0)) return "max_seen_through_share must be in [0, 1]";
  if (!(free_space_margin >= 0.0)) return "free_space_margin must be >= 0";
  if (!(max_position_std >= 0.0) || !std::isfinite(max_position_std)) return "max_position_std must be finite and >= 0";
  return "";
}

FieldOfView FieldOfView::fullCircle(double max_range) {
  FieldOfView view;
  view.max_range_ = max_range;
  return view;
}

FieldOfView FieldOfView::arc(double bearing_min, double bearing_max, double max_range) {
  if (!(bearing_min >= -M_PI && bearing_min <= bearing_max && bearing_max <= M_PI))
    throw std::invalid_argument("field of view: bearings must satisfy -pi <= min <= max <= pi");
  FieldOfView view;
  view.full_circle_ = false;
  view.max_range_ = max_range;
  // p lies at or after edge_min (counter-clockwise) when edge_min x p >= 0, and at or before
  // edge_max when p x edge_max >= 0; an arc wider than pi is everything not strictly between.
  view.edge_min_ = Point2(std::cos(bearing_min), std::sin(bearing_min));
  view.edge_max_ = Point2(std::cos(bearing_max), std::sin(bearing_max));
  view.wide_ = bearing_max - bearing_min > M_PI;
  view.width_ = bearing_max - bearing_min;
  return view;
}

FieldOfView fieldOfView(const Scan& scan, double max_range) {
  if (scan.full_circle) return FieldOfView::fullCircle(max_range);
  double lo = M_PI, hi = -M_PI;
  for (double b : scan.bearings)
    if (std::isfinite(b)) lo = std::min(lo, normalizeAngle(b)), hi = std::max(hi, normalizeAngle(b));
  if (lo > hi) lo = hi = 0.0;  // no usable bearing: sees nothing but straight ahead
  return FieldOfView::arc(lo, hi, max_range);
}

FreeSpace freeSpace(const Scan& scan, double max_range) {
  std::vector<std::pair<double, double>> beams;
  beams.reserve(scan.size());
  for (std::size_t i = 0; i < scan.size() && i < scan.bearings.size(); ++i) {
    const double r = scan.ranges[i], b = scan.bearings[i];
    if (!std::isfinite(b)) continue;
    const bool returned = std::isfinite(r) && r > 0.0 && r < max_range;
    beams.emplace_back(normalizeAngle(b), returned ? r : std::nan(""));
  }
  std::sort(beams.begin(), beams.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  FreeSpace space;
  space.full_circle = scan.full_circle;
  for (const auto& [bearing, range] : beams) space.bearings.push_back(bearing), space.ranges.push_back(range);
  return space;
}

double seenThroughShare(const Points2& source, const Pose2& pose, const FreeSpace& target, double margin,
                        std::size_t* tested_out) {
  std::size_t tested = 0, seen_through = 0;
  const std::size_t n = target.bearings.size();
  if (n >= 2) {
    const RigidMotion2 motion(pose);
    for (const Point2& p : source) {
      const Point2 moved = motion(p);
      const double bearing = std::atan2(moved.y(), moved.x()), range = moved.norm();
      // Beams k-1 and k bracket the bearing; one more on each side allows for the step.
      const std::size_t k = std::size_t(std::lower_bound(target.bearings.begin(), target.bearings.end(), bearing) -
                                        target.bearings.begin());
      if (!target.full_circle && (k == 0 || k == n)) continue;  // outside the span
      bool any = false, all_beyond = true;
      for (long offset = -2; offset <= 1; ++offset) {
        long i = long(k) + offset;
        if (target.full_circle) i = (i % long(n) + long(n)) % long(n);
        else if (i < 0 || i >= long(n)) continue;
        const double r = target.ranges[std::size_t(i)];
        if (std::isnan(r)) continue;
        any = true;
        all_beyond = all_beyond && r > range + margin;
      }
      if (!any) continue;
      ++tested;
      seen_through += all_beyond;
    }
  }
  if (tested_out) *tested_out = tested;
  return tested > 0 ? double(seen_through) / double(tested) : 0.0;
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
