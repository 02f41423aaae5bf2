// Points of a scan in the plane, rigid transforms of them, and a k-d tree over them
// (nanoflann behind a small interface, so that no caller sees its templates).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <limits>
#include <memory>
#include <vector>

#include "laser_loop_closure/core/geometry/scan.hpp"
#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc {

using Point2 = Eigen::Vector2d;
using Points2 = std::vector<Point2, Eigen::aligned_allocator<Point2>>;

/// The returns of a scan as points, in beam order: every beam with a finite range in
/// (0, max_range); everything else (no return, NaN, negative, too far) is left out.
Points2 scanPoints(const Scan& scan, double max_range);

/// The point p of a frame placed at `pose`, expressed in the pose's parent frame.
inline Point2 transformPoint(const Pose2& pose, const Point2& p) {
  const double c = std::cos(pose.theta), s = std::sin(pose.theta);
  return {pose.x + c * p.x() - s * p.y(), pose.y + s * p.x() + c * p.y()};
}
Points2 transformPoints(const Pose2& pose, const Points2& points);

/// A pose's rotation and translation, its sine and cosine computed once, for moving many points.
struct RigidMotion2 {
  explicit RigidMotion2(const Pose2& pose) : c(std::cos(pose.theta)), s(std::sin(pose.theta)), x(pose.x), y(pose.y) {}
  Point2 operator()(const Point2& p) const { return {x + c * p.x() - s * p.y(), y + s * p.x() + c * p.y()}; }
  double c, s, x, y;
};

/// Exact nearest-neighbour queries over a fixed set of points (it keeps a copy).
class KdTree2 {
 public:
  explicit KdTree2(Points2 points);
  ~KdTree2();
  KdTree2(const KdTree2&) = delete;
  KdTree2& operator=(const KdTree2&) = delete;

  const Points2& points() const { return points_; }
  std::size_t size() const { return points_.size(); }
  /// Index of the point nearest to q and its squared distance; false when the set is empty or
  /// no point lies within max_squared_distance (a bound prunes the search: far queries are cheap).
  bool nearest(const Point2& q, std::size_t* index, double* squared_distance,
               double max_squared_distance = std::numeric_limits<double>::infinity()) const;
  /// Up to k nearest points, nearest first (fewer when the set is smaller).
  void kNearest(const Point2& q, std::size_t k, std::vector<std::size_t>* indices,
                std::vector<double>* squared_distances) const;

 private:
  struct Index;
  Points2 points_;
  std::unique_ptr<Index> index_;
};

/// Unit normals of a scan's points, one per point: the direction of least spread of the
/// point and its `neighbours` nearest points (principal component analysis), or zero where
/// fewer than three points are within `max_radius` (an isolated point has no surface).
Points2 estimateNormals(const KdTree2& tree, std::size_t neighbours, double max_radius);

}  // namespace llc
