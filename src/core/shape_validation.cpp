#include "laser_loop_closure/core/shape_validation.hpp"

#include <cstdio>

namespace llc {

std::string ShapeValidationOptions::validate() const {
  if (!(max_distance > 0.0)) return "max_distance must be > 0";
  if (!(min_inlier_share >= 0.0 && min_inlier_share <= 1.0)) return "min_inlier_share must be in [0, 1]";
  return "";
}

ShapeValidationResult validateShape(const Points2& source, const KdTree2& target, const Pose2& pose,
                                    const ShapeValidationOptions& options) {
  ShapeValidationResult result;
  result.points = source.size();
  if (source.empty() || target.size() == 0) {
    result.reject_reason = "no points to compare";
    return result;
  }
  const double limit_sq = options.max_distance * options.max_distance;
  std::size_t inliers = 0;
  const RigidMotion2 motion(pose);
  for (const Point2& p : source) {
    std::size_t index;
    double distance_sq;
    if (target.nearest(motion(p), &index, &distance_sq) && distance_sq <= limit_sq) ++inliers;
  }
  result.inlier_share = double(inliers) / double(source.size());
  result.accepted = result.inlier_share >= options.min_inlier_share;
  if (!result.accepted) {
    char text[96];
    std::snprintf(text, sizeof text, "inlier share %.3f below %.3f", result.inlier_share, options.min_inlier_share);
    result.reject_reason = text;
  }
  return result;
}

}  // namespace llc
