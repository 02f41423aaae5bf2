#include "laser_loop_closure/core/io/g2o_io.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>

#include "laser_loop_closure/core/common/file_util.hpp"
#include "laser_loop_closure/core/geometry/se2_jacobians.hpp"

namespace llc {

namespace {
std::string where(const std::string& path, std::size_t line) { return path + ":" + std::to_string(line) + ": "; }

/// A field read as a number must end where the text does: "15xyz" is not 15.
void refuseTrailingText(std::istringstream& fields, const std::string& path, std::size_t line, const std::string& tag) {
  std::string rest;
  if (fields >> rest) throw G2oError(where(path, line) + tag + ": unexpected text '" + rest + "' after its last field");
}
}  // namespace

PoseGraph2 readG2o(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw G2oError(path + ": no such file or not readable");
  std::map<std::size_t, Pose2> vertices;
  PoseGraph2 graph;
  std::string text;
  std::size_t line = 0, max_id = 0;
  bool any_id = false;
  while (std::getline(in, text)) {
    ++line;
    std::istringstream fields(text);
    std::string tag;
    if (!(fields >> tag) || tag[0] == '#') continue;
    if (tag == "VERTEX_SE2") {
      long id;
      Pose2 p;
      if (!(fields >> id >> p.x >> p.y >> p.theta) || id < 0 || !std::isfinite(p.x) || !std::isfinite(p.y) ||
          !std::isfinite(p.theta))
        throw G2oError(where(path, line) + "VERTEX_SE2 needs: id x y theta (finite, id >= 0)");
      refuseTrailingText(fields, path, line, tag);
      p.theta = normalizeAngle(p.theta);
      if (!vertices.emplace(std::size_t(id), p).second) throw G2oError(where(path, line) + "vertex " + std::to_string(id) + " twice");
      max_id = std::max(max_id, std::size_t(id));
      any_id = true;
    } else if (tag == "EDGE_SE2") {
      long from, to;
      PoseEdge e;
      double info[6];
      if (!(fields >> from >> to >> e.measurement.x >> e.measurement.y >> e.measurement.theta)) 
        throw G2oError(where(path, line) + "EDGE_SE2 needs: i j dx dy dtheta I11 I12 I13 I22 I23 I33");
      for (double& v : info)
        if (!(fields >> v)) throw G2oError(where(path, line) + "EDGE_SE2 needs: i j dx dy dtheta I11 I12 I13 I22 I23 I33");
      refuseTrailingText(fields, path, line, tag);
      if (from < 0 || to < 0 || from == to) throw G2oError(where(path, line) + "EDGE_SE2 needs two different ids >= 0");
      e.from = std::size_t(from);
      e.to = std::size_t(to);
      e.measurement.theta = normalizeAngle(e.measurement.theta);
      e.information << info[0], info[1], info[2], info[1], info[3], info[4], info[2], info[4], info[5];
      if (!e.information.allFinite() || !std::isfinite(e.measurement.x + e.measurement.y + e.measurement.theta))
        throw G2oError(where(path, line) + "EDGE_SE2 values must be finite");
      // The information must be positive definite (LDLT of a 3x3: all pivots > 0).
      if (!(info[0] > 0.0) || !(info[0] * info[3] - info[1] * info[1] > 0.0) || !(e.information.determinant() > 0.0))
        throw G2oError(where(path, line) + "EDGE_SE2 information matrix is not positive definite");
      max_id = std::max({max_id, e.from, e.to});
      any_id = true;
      graph.edges.push_back(e);
    }
  }
  if (!any_id) throw G2oError(path + ": no VERTEX_SE2 or EDGE_SE2 line");
  const std::size_t n = max_id + 1;
  graph.had_vertices = !vertices.empty();
  if (graph.had_vertices) {
    if (vertices.size() != n)
      throw G2oError(path + ": vertex ids must be 0.." + std::to_string(n - 1) + " without gaps (" +
                     std::to_string(vertices.size()) + " vertices)");
    for (const auto& [id, pose] : vertices) graph.poses.push_back(pose);
  } else {
    // No vertices: compose the odometry chain from pose 0 at the origin. Every pose needs an
    // edge into it, so ids beyond the edge count are refused before the chain is sized by them.
    if (n > graph.edges.size() + 1)
      throw G2oError(path + ": no VERTEX_SE2 lines, and edge ids up to " + std::to_string(max_id) + " for only " +
                     std::to_string(graph.edges.size()) + " edges: the odometry chain 0.." + std::to_string(max_id) + " cannot be whole");
    std::vector<const PoseEdge*> step(n, nullptr);
    for (const PoseEdge& e : graph.edges)
      if (e.to == e.from + 1 && !step[e.to]) step[e.to] = &e;
    graph.poses.assign(n, Pose2{});
    for (std::size_t k = 1; k < n; ++k) {
      if (!step[k]) throw G2oError(path + ": no VERTEX_SE2 lines and no odometry edge " + std::to_string(k - 1) + " -> " + std::to_string(k));
      graph.poses[k] = compose(graph.poses[k - 1], step[k]->measurement);
    }
  }
  return graph;
}

void writeG2o(const PoseGraph2& graph, const std::string& path) {
  AtomicTextFile out(path);
  out << std::setprecision(17);
  for (std::size_t i = 0; i < graph.poses.size(); ++i)
    out << "VERTEX_SE2 " << i << ' ' << graph.poses[i].x << ' ' << graph.poses[i].y << ' ' << graph.poses[i].theta << '\n';
  for (const PoseEdge& e : graph.edges) {
    const Eigen::Matrix3d& m = e.information;
    out << "EDGE_SE2 " << e.from << ' ' << e.to << ' ' << e.measurement.x << ' ' << e.measurement.y << ' '
        << e.measurement.theta << ' ' << m(0, 0) << ' ' << m(0, 1) << ' ' << m(0, 2) << ' ' << m(1, 1) << ' '
        << m(1, 2) << ' ' << m(2, 2) << '\n';
  }
  try {
    out.commit();
  } catch (const std::runtime_error& e) {
    throw G2oError(e.what());
  }
}

Eigen::Vector3d edgeError(const PoseEdge& edge, const std::vector<Pose2>& poses) {
  return toVector(between(edge.measurement, between(poses[edge.from], poses[edge.to])));
}

double chiSquared(const std::vector<PoseEdge>& edges, const std::vector<Pose2>& poses) {
  double sum = 0.0;
  for (const PoseEdge& e : edges) {
    const Eigen::Vector3d r = edgeError(e, poses);
    sum += r.dot(e.information * r);
  }
  return sum;
}

}  // namespace llc
