// 2D pose graphs in g2o's text format: VERTEX_SE2 id x y theta and
// EDGE_SE2 i j dx dy dtheta I11 I12 I13 I22 I23 I33 (upper triangle of the information).
#pragma once

#include <Eigen/Core>
#include <stdexcept>
#include <string>
#include <vector>

#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc {

/// A relative-pose constraint: pose `to` seen from pose `from` is `measurement`.
struct PoseEdge {
  std::size_t from = 0, to = 0;
  Pose2 measurement;
  Eigen::Matrix3d information = Eigen::Matrix3d::Identity();  ///< symmetric, of (x, y, theta)
};

struct PoseGraph2 {
  std::vector<Pose2> poses;  ///< index = vertex id (ids are 0..n-1)
  std::vector<PoseEdge> edges;  ///< in file order
  bool had_vertices = false;  ///< false: the poses were composed from the odometry chain
};

/// Thrown for an unreadable or malformed file; what() names file and line.
class G2oError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Reads a 2D g2o file. Vertex ids must be 0..n-1 (any order); without VERTEX_SE2 lines every
/// pose is composed from pose 0 at the origin along the edges i -> i+1. Blank lines, comments
/// (#) and other tags (FIX, ...) are skipped.
PoseGraph2 readG2o(const std::string& path);
/// Writes every vertex, then every edge, with 17 significant digits.
void writeG2o(const PoseGraph2& graph, const std::string& path);

/// g2o's error of one edge under poses: t2v(Z^-1 (X_from^-1 X_to)), angle wrapped.
Eigen::Vector3d edgeError(const PoseEdge& edge, const std::vector<Pose2>& poses);
/// Sum over edges of e^T Omega e.
double chiSquared(const std::vector<PoseEdge>& edges, const std::vector<Pose2>& poses);

}  // namespace llc
