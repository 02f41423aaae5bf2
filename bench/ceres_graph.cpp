// The Ceres yardstick for `llc graph`: a batch pose-graph solve of a 2D g2o file with
// Levenberg-Marquardt and sparse normal Cholesky, pose 0 held fixed, started from the file's
// poses (or the odometry chain when it has none), the same error as g2o and llc graph.
// Usage: llc_ceres_graph IN.g2o [OUT.g2o]; prints chi2=<value> and seconds=<value> last.
#include <ceres/ceres.h>

#include <chrono>
#include <iomanip>
#include <iostream>

#include "laser_loop_closure/core/io/g2o_io.hpp"

namespace {

template <class T>
T wrap(const T& angle) {
  // Into [-pi, pi) with operations Jets support.
  const T two_pi = T(2.0 * M_PI);
  return angle - two_pi * ceres::floor((angle + T(M_PI)) / two_pi);
}

/// sqrt(Omega) * t2v(Z^-1 (Xi^-1 Xj)).
struct EdgeCost {
  EdgeCost(const llc::PoseEdge& e) : z(e.measurement) {
    sqrt_information = e.information.llt().matrixU();
  }
  template <class T>
  bool operator()(const T* a, const T* b, T* residual) const {
    const T ca = ceres::cos(a[2]), sa = ceres::sin(a[2]);
    const T dx = b[0] - a[0], dy = b[1] - a[1];
    // h = Xi^-1 Xj
    const T hx = ca * dx + sa * dy, hy = -sa * dx + ca * dy, ht = b[2] - a[2];
    // e = Z^-1 h
    const T cz = T(std::cos(z.theta)), sz = T(std::sin(z.theta));
    const T ex = cz * (hx - T(z.x)) + sz * (hy - T(z.y));
    const T ey = -sz * (hx - T(z.x)) + cz * (hy - T(z.y));
    const T et = wrap(ht - T(z.theta));
    for (int r = 0; r < 3; ++r)
      residual[r] = T(sqrt_information(r, 0)) * ex + T(sqrt_information(r, 1)) * ey + T(sqrt_information(r, 2)) * et;
    return true;
  }
  llc::Pose2 z;
  Eigen::Matrix3d sqrt_information;
};

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: llc_ceres_graph IN.g2o [OUT.g2o]\n";
    return 2;
  }
  llc::PoseGraph2 graph;
  try {
    graph = llc::readG2o(argv[1]);
  } catch (const llc::G2oError& e) {
    std::cerr << "llc_ceres_graph: error: " << e.what() << "\n";
    return 1;
  }
  std::vector<std::array<double, 3>> x(graph.poses.size());
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = {graph.poses[i].x, graph.poses[i].y, graph.poses[i].theta};
  const auto start = std::chrono::steady_clock::now();
  ceres::Problem problem;
  for (const llc::PoseEdge& e : graph.edges)
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<EdgeCost, 3, 3, 3>(new EdgeCost(e)), nullptr,
                             x[e.from].data(), x[e.to].data());
  problem.SetParameterBlockConstant(x[0].data());
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  options.max_num_iterations = 200;
  options.function_tolerance = 1e-10;
  options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (std::size_t i = 0; i < x.size(); ++i) graph.poses[i] = {x[i][0], x[i][1], llc::normalizeAngle(x[i][2])};
  if (argc > 2) llc::writeG2o(graph, argv[2]);
  std::cout << "iterations=" << summary.iterations.size() << " termination=" << ceres::TerminationTypeToString(summary.termination_type)
            << "\nchi2=" << std::setprecision(10) << llc::chiSquared(graph.edges, graph.poses) << "\nseconds=" << std::setprecision(4)
            << seconds << "\n";
  return 0;
}
