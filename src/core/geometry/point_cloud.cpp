#include "laser_loop_closure/core/geometry/point_cloud.hpp"

#include <cmath>
#include <limits>
#include <nanoflann.hpp>

namespace llc {

Points2 scanPoints(const Scan& scan, double max_range) {
  Points2 points;
  points.reserve(scan.size());
  for (std::size_t i = 0; i < scan.size() && i < scan.bearings.size(); ++i) {
    const double r = scan.ranges[i], b = scan.bearings[i];
    if (!(std::isfinite(r) && r > 0.0 && r < max_range && std::isfinite(b))) continue;
    points.emplace_back(r * std::cos(b), r * std::sin(b));
  }
  return points;
}

Points2 transformPoints(const Pose2& pose, const Points2& points) {
  Points2 out;
  out.reserve(points.size());
  const RigidMotion2 motion(pose);
  for (const Point2& p : points) out.push_back(motion(p));
  return out;
}

namespace {
/// nanoflann's dataset interface over the points.
struct Adaptor {
  const Points2* points;
  std::size_t kdtree_get_point_count() const { return points->size(); }
  double kdtree_get_pt(std::size_t i, std::size_t dim) const { return (*points)[i][int(dim)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const { return false; }
};
using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Adaptor>, Adaptor, 2, std::size_t>;
}  // namespace

struct KdTree2::Index {
  Adaptor adaptor;
  Tree tree;
  explicit Index(const Points2* points)
      : adaptor{points}, tree(2, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(10)) {
    tree.buildIndex();
  }
};

KdTree2::KdTree2(Points2 points) : points_(std::move(points)), index_(std::make_unique<Index>(&points_)) {}
KdTree2::~KdTree2() = default;

bool KdTree2::nearest(const Point2& q, std::size_t* index, double* squared_distance, double max_squared_distance) const {
  if (points_.empty()) return false;
  const double query[2] = {q.x(), q.y()};
  std::size_t i = 0;
  double d = 0.0;
  nanoflann::KNNResultSet<double, std::size_t> result(1);
  result.init(&i, &d);
  // The bound is the result set's worst distance: branches beyond it are never visited. One
  // step above it, since nanoflann keeps only points strictly nearer (the bound is inclusive).
  if (max_squared_distance < std::numeric_limits<double>::infinity())
    d = std::nextafter(max_squared_distance, std::numeric_limits<double>::infinity());
  index_->tree.findNeighbors(result, query, nanoflann::SearchParams());
  if (result.size() == 0) return false;
  *index = i;
  *squared_distance = d;
  return true;
}

void KdTree2::kNearest(const Point2& q, std::size_t k, std::vector<std::size_t>* indices,
                       std::vector<double>* squared_distances) const {
  k = std::min(k, points_.size());
  indices->resize(k);
  squared_distances->resize(k);
  if (k == 0) return;
  const double query[2] = {q.x(), q.y()};
  const std::size_t found = index_->tree.knnSearch(query, k, indices->data(), squared_distances->data());
  indices->resize(found);
  squared_distances->resize(found);
}

Points2 estimateNormals(const KdTree2& tree, std::size_t neighbours, double max_radius) {
  Points2 normals(tree.size(), Point2::Zero());
  std::vector<std::size_t> indices;
  std::vector<double> distances;
  const double max_squared = max_radius * max_radius;
  for (std::size_t i = 0; i < tree.size(); ++i) {
    tree.kNearest(tree.points()[i], neighbours + 1, &indices, &distances);
    Point2 mean = Point2::Zero();
    std::size_t used = 0;
    for (std::size_t k = 0; k < indices.size(); ++k)
      if (distances[k] <= max_squared) mean += tree.points()[indices[k]], ++used;
    if (used < 3) continue;
    mean /= double(used);
    Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
    for (std::size_t k = 0; k < indices.size(); ++k) {
      if (distances[k] > max_squared) continue;
      const Point2 d = tree.points()[indices[k]] - mean;
      scatter += d * d.transpose();
    }
    // The major axis of a symmetric 2x2 matrix in closed form; the normal is perpendicular.
    const double major = 0.5 * std::atan2(2.0 * scatter(0, 1), scatter(0, 0) - scatter(1, 1));
    normals[i] = Point2(-std::sin(major), std::cos(major));
  }
  return normals;
}

}  // namespace llc
