#include "laser_loop_closure/core/backend/marginalization.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>

#include "laser_loop_closure/core/backend/esdf.hpp"
#include "laser_loop_closure/core/geometry/se2_jacobians.hpp"

namespace llc {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

/// The graph while poses leave it: dead constraints stay in place (their indices are kept).
struct WorkingGraph {
  std::vector<PoseEdge> edges;
  std::vector<char> alive;
  std::vector<std::vector<std::size_t>> incident;  ///< per pose, its constraints (dead ones too)
  std::vector<std::size_t> degree;                 ///< per pose, its live constraints

  void add(const PoseEdge& edge) {
    incident[edge.from].push_back(edges.size());
    incident[edge.to].push_back(edges.size());
    ++degree[edge.from];
    ++degree[edge.to];
    edges.push_back(edge);
    alive.push_back(1);
  }
  void remove(std::size_t e) {
    alive[e] = 0;
    --degree[edges[e].from];
    --degree[edges[e].to];
  }
};

/// The covariance of the error of a relative-pose constraint (from slot a to slot b of a
/// neighbourhood whose slot 0 is held fixed) under covariance sigma of slots 1 .., at the
/// constraint's own measurement: J Sigma J^T with J the error's Jacobians.
Eigen::Matrix3d relativeCovariance(const Eigen::Matrix3d& ja, const Eigen::Matrix3d& jb, std::size_t a, std::size_t b,
                                   const MatrixXd& sigma) {
  auto block = [&](std::size_t i, std::size_t j) -> Eigen::Matrix3d {
    if (i == 0 || j == 0) return Eigen::Matrix3d::Zero();
    return sigma.block<3, 3>(3 * long(i - 1), 3 * long(j - 1));
  };
  const Eigen::Matrix3d c = ja * block(a, a) * ja.transpose() + ja * block(a, b) * jb.transpose() +
                            jb * block(b, a) * ja.transpose() + jb * block(b, b) * jb.transpose();
  return 0.5 * (c + c.transpose());
}

/// A candidate tree constraint between neighbours p < t (slots of the neighbourhood, 0 its
/// root): their relative pose now, with its marginal covariance's inverse, and how well it is
/// known (the log-determinant of that covariance: smaller is better).
struct Candidate {
  double log_det;
  std::size_t p, t;
  PoseEdge edge;
};

/// Every pair of neighbours (`blanket`, oldest first) as a candidate, best known first; sigma
/// is the covariance of neighbours 1 .. with neighbour 0 held fixed (block j - 1: neighbour j).
std::vector<Candidate> candidatePairs(const std::vector<std::size_t>& blanket, const std::vector<Pose2>& poses,
                                      const MatrixXd& sigma) {
  std::vector<Candidate> candidates;
  for (std::size_t t = 1; t < blanket.size(); ++t) {
    for (std::size_t p = 0; p < t; ++p) {
      PoseEdge edge;
      edge.from = blanket[p];
      edge.to = blanket[t];
      edge.measurement = between(poses[edge.from], poses[edge.to]);
      Eigen::Matrix3d ja, jb;
      linearizeEdge(edge, poses[edge.from], poses[edge.to], &ja, &jb);
      const Eigen::LLT<Eigen::Matrix3d> factor(relativeCovariance(ja, jb, p, t, sigma));
      if (factor.info() != Eigen::Success) continue;
      const Eigen::Matrix3d l = factor.matrixL();
      const double log_det = 2.0 * (std::log(l(0, 0)) + std::log(l(1, 1)) + std::log(l(2, 2)));
      const Eigen::Matrix3d information = factor.solve(Eigen::Matrix3d::Identity());
      edge.information = 0.5 * (information + information.transpose());
      if (std::isfinite(log_det) && edge.information.allFinite()) candidates.push_back({log_det, p, t, edge});
    }
  }
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) { return a.log_det < b.log_det; });
  return candidates;
}

/// The tree over the neighbours: each one with needs_older[t] first linked to its best older
/// neighbour, then the best known pairs that join parts not yet joined (Kruskal: a
/// maximum-information spanning tree). False when the candidates span no tree.
bool spanningTree(const std::vector<Candidate>& candidates, const std::vector<char>& needs_older,
                  std::vector<PoseEdge>* tree, std::vector<std::pair<std::size_t, std::size_t>>* slots) {
  const std::size_t m = needs_older.size();
  std::vector<std::size_t> part(m);
  for (std::size_t i = 0; i < m; ++i) part[i] = i;
  auto find = [&](std::size_t i) {
    while (part[i] != i) i = part[i] = part[part[i]];
    return i;
  };
  auto join = [&](const Candidate& c) {
    const std::size_t a = find(c.p), b = find(c.t);
    if (a == b) return;
    part[a] = b;
    tree->push_back(c.edge);
    slots->emplace_back(c.p, c.t);
  };
  for (std::size_t t = 1; t < m; ++t) {
    if (!needs_older[t]) continue;
    const auto best = std::find_if(candidates.begin(), candidates.end(), [&](const Candidate& c) { return c.t == t; });
    if (best == candidates.end()) return false;
    join(*best);
  }
  for (const Candidate& c : candidates) join(c);
  return tree->size() + 1 == m;
}

/// Marginalises pose k out of the graph (its constraints replaced by a tree over its
/// neighbours). False, and nothing changed, when the neighbourhood's information cannot be
/// factorised. *kl receives what the tree lost (nats; 0 for fewer than two neighbours).
bool retirePose(WorkingGraph& graph, const std::vector<Pose2>& poses, std::size_t k, double* kl,
                std::vector<std::size_t>* neighbours) {
  *kl = 0.0;
  std::vector<std::size_t> touching, blanket;
  for (std::size_t e : graph.incident[k]) {
    if (!graph.alive[e]) continue;
    touching.push_back(e);
    const PoseEdge& edge = graph.edges[e];
    blanket.push_back(edge.from == k ? edge.to : edge.from);
  }
  std::sort(blanket.begin(), blanket.end());
  blanket.erase(std::unique(blanket.begin(), blanket.end()), blanket.end());
  const std::size_t m = blanket.size();
  *neighbours = blanket;
  auto slot = [&](std::size_t pose) -> std::size_t {  // k is slot 0, its neighbours 1 .. m
    return pose == k ? 0 : std::size_t(std::lower_bound(blanket.begin(), blanket.end(), pose) - blanket.begin()) + 1;
  };
  auto kill = [&] {
    for (std::size_t e : touching) graph.remove(e);
    graph.incident[k].clear();
  };
  if (m < 2) {  // a leaf: its constraints say nothing about one neighbour alone (no absolute prior)
    kill();
    return true;
  }
  // 0.5 (r + J dx)^T W (r + J dx) summed over k's constraints: information h, gradient g.
  const long n = 3 * long(m + 1);
  MatrixXd h = MatrixXd::Zero(n, n);
  VectorXd g = VectorXd::Zero(n);
  for (std::size_t e : touching) {
    const PoseEdge& edge = graph.edges[e];
    Eigen::Matrix3d ja, jb;
    const Eigen::Vector3d r = linearizeEdge(edge, poses[edge.from], poses[edge.to], &ja, &jb);
    const long a = 3 * long(slot(edge.from)), b = 3 * long(slot(edge.to));
    const Eigen::Matrix3d wa = ja.transpose() * edge.information, wb = jb.transpose() * edge.information;
    h.block<3, 3>(a, a) += wa * ja;
    h.block<3, 3>(b, b) += wb * jb;
    h.block<3, 3>(a, b) += wa * jb;
    h.block<3, 3>(b, a) += wb * ja;
    g.segment<3>(a) += wa * r;
    g.segment<3>(b) += wb * r;
  }
  const Eigen::LLT<Eigen::Matrix3d> own(h.topLeftCorner<3, 3>());
  if (own.info() != Eigen::Success) return false;
  // Schur complement: the neighbours' information with k marginalised out; then the gauge
  // fixed at the oldest neighbour (slot 1) so that what is left is positive definite.
  const MatrixXd cross = h.bottomLeftCorner(n - 3, 3);
  const MatrixXd marginal = h.bottomRightCorner(n - 3, n - 3) - cross * own.solve(cross.transpose());
  const VectorXd marginal_g = g.tail(n - 3) - cross * own.solve(g.head<3>());
  const long free = 3 * long(m - 1);
  const MatrixXd rooted = 0.5 * (marginal.bottomRightCorner(free, free) + marginal.bottomRightCorner(free, free).transpose());
  const Eigen::LLT<MatrixXd> rooted_factor(rooted);
  if (rooted_factor.info() != Eigen::Success) return false;
  const MatrixXd sigma = rooted_factor.solve(MatrixXd::Identity(free, free));
  if (!sigma.allFinite()) return false;
  // A neighbour whose only link from an older pose went through k needs one again in the tree,
  // so that the graph can still be rebuilt pose by pose.
  std::vector<char> needs_older(m, 0);
  for (std::size_t t = 1; t < m; ++t) {
    const std::size_t pose = blanket[t];
    bool linked = false;
    for (std::size_t e : graph.incident[pose])
      linked = linked || (graph.alive[e] && graph.edges[e].to == pose && graph.edges[e].from < pose &&
                          graph.edges[e].from != k);
    needs_older[t] = !linked;
  }
  std::vector<PoseEdge> tree;
  std::vector<std::pair<std::size_t, std::size_t>> tree_slots;
  if (!spanningTree(candidatePairs(blanket, poses, sigma), needs_older, &tree, &tree_slots)) return false;
  // The tree's linear model at the current poses (rows: its constraints; columns: neighbours 1 ..).
  MatrixXd jacobian = MatrixXd::Zero(free, free), weight = MatrixXd::Zero(free, free);
  for (std::size_t i = 0; i < tree.size(); ++i) {
    const auto [p, t] = tree_slots[i];
    Eigen::Matrix3d ja, jb;
    linearizeEdge(tree[i], poses[tree[i].from], poses[tree[i].to], &ja, &jb);
    const long row = 3 * long(i);
    jacobian.block<3, 3>(row, 3 * long(t - 1)) = jb;
    if (p > 0) jacobian.block<3, 3>(row, 3 * long(p - 1)) = ja;
    weight.block<3, 3>(row, row) = tree[i].information;
  }
  // Its measurements: such that at the current poses the tree pulls on the neighbours exactly
  // as the dense marginal does (the same gradient), so a graph at its optimum stays there to
  // first order: J^T W e = g, e = W^-1 J^-T g, each constraint's error e_i = t2v(Z_i^-1 P_i).
  const Eigen::PartialPivLU<MatrixXd> jacobian_lu(jacobian.transpose());
  const VectorXd pull = jacobian_lu.solve(marginal_g.tail(free));
  if (!pull.allFinite()) return false;
  for (std::size_t i = 0; i < tree.size(); ++i) {
    const Eigen::Vector3d error = tree[i].information.ldlt().solve(pull.segment<3>(3 * long(i)));
    if (!error.allFinite()) return false;
    tree[i].measurement = compose(tree[i].measurement, inverse(toPose(error)));
  }
  // What the tree lost, KL(dense || tree) = 0.5 (tr(L_t S) - dim - ln det(L_t S) + d^T L_t d)
  // with d the difference of the two means (the minimisers -L^-1 g of each).
  const MatrixXd tree_information = jacobian.transpose() * weight * jacobian;
  const Eigen::LLT<MatrixXd> tree_factor(tree_information);
  if (tree_factor.info() == Eigen::Success) {
    double log_det_tree = 0.0, log_det_dense = 0.0;
    for (long i = 0; i < free; ++i) {
      log_det_tree += 2.0 * std::log(tree_factor.matrixLLT()(i, i));
      log_det_dense += 2.0 * std::log(rooted_factor.matrixLLT()(i, i));
    }
    const double trace = (tree_information.cwiseProduct(sigma)).sum();  // tr(A B) for symmetric A, B
    const VectorXd d = tree_factor.solve(marginal_g.tail(free)) - rooted_factor.solve(marginal_g.tail(free));
    const double shift = d.dot(tree_information * d);
    *kl = std::max(0.0, 0.5 * (trace - double(free) - log_det_tree + log_det_dense + shift));
  }
  kill();
  for (const PoseEdge& edge : tree) graph.add(edge);
  return true;
}

void checkInput(const std::vector<Pose2>& poses, const std::vector<PoseEdge>& edges, const std::vector<char>& retire) {
  if (retire.size() != poses.size())
    throw std::invalid_argument("marginalizePoses: " + std::to_string(poses.size()) + " poses but " +
                                std::to_string(retire.size()) + " retire flags");
  std::vector<char> augmented(poses.size(), 0);
  for (const Pose2& pose : poses)
    if (!isFinite(pose)) throw std::invalid_argument("marginalizePoses: a pose is not finite");
  for (const PoseEdge& e : edges) {
    if (e.from >= poses.size() || e.to >= poses.size() || e.from == e.to)
      throw std::invalid_argument("marginalizePoses: constraint " + std::to_string(e.from) + " -> " + std::to_string(e.to) +
                                  " joins unknown poses");
    if (!isFinite(e.measurement) || !e.information.allFinite())
      throw std::invalid_argument("marginalizePoses: a constraint is not finite");
    if (e.from < e.to) augmented[e.to] = 1;
  }
  for (std::size_t i = 1; i < poses.size(); ++i)
    if (!augmented[i]) throw std::invalid_argument("marginalizePoses: pose " + std::to_string(i) + " has no constraint from an older pose");
}

}  // namespace

PoseGraphReduction marginalizePoses(const std::vector<Pose2>& poses, const std::vector<PoseEdge>& edges,
                                    const std::vector<char>& retire) {
  checkInput(poses, edges, retire);
  WorkingGraph graph;
  graph.incident.resize(poses.size());
  graph.degree.assign(poses.size(), 0);
  for (const PoseEdge& edge : edges) graph.add(edge);
  PoseGraphReduction out;
  std::vector<char> gone(poses.size(), 0);
  std::size_t trees = 0;
  double kl_sum = 0.0;
  // Fewest constraints first (minimum degree, as sparse elimination orders): small
  // neighbourhoods are marginalised exactly or nearly, and no pose gathers the others' links.
  std::set<std::pair<std::size_t, std::size_t>> queue;  // (live constraints, pose)
  std::vector<std::size_t> queued_degree(poses.size(), 0);  // the key each retired-to-be pose is queued under
  for (std::size_t k = 1; k < poses.size(); ++k)
    if (retire[k]) queue.insert({queued_degree[k] = graph.degree[k], k});
  std::vector<std::size_t> neighbours;
  while (!queue.empty()) {
    const std::size_t k = queue.begin()->second;
    queue.erase(queue.begin());
    double kl = 0.0;
    const std::size_t edges_before = graph.edges.size();
    const bool retired = retirePose(graph, poses, k, &kl, &neighbours);
    for (std::size_t other : neighbours)  // their degrees changed: (again) in the queue under the new one
      if (retire[other] && !gone[other] && other != 0) {
        queue.erase({queued_degree[other], other});
        queue.insert({queued_degree[other] = graph.degree[other], other});
      }
    if (!retired) {
      ++out.kept_unfactorizable;
      continue;
    }
    gone[k] = 1;
    ++out.retired;
    out.constraints_added += graph.edges.size() - edges_before;
    if (graph.edges.size() > edges_before) {
      ++trees;
      kl_sum += kl;
      out.max_kl = std::max(out.max_kl, kl);
    }
  }
  out.mean_kl = trees ? kl_sum / double(trees) : 0.0;
  // Renumber, then order: pose i's first augmentation, then the rest of what reaches pose i.
  std::vector<std::size_t> index(poses.size(), 0);
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (gone[i]) continue;
    index[i] = out.kept.size();
    out.kept.push_back(i);
    out.poses.push_back(poses[i]);
  }
  std::vector<std::vector<PoseEdge>> reaching(out.kept.size());
  for (std::size_t e = 0; e < graph.edges.size(); ++e) {
    if (!graph.alive[e]) continue;
    PoseEdge edge = graph.edges[e];
    edge.from = index[edge.from];
    edge.to = index[edge.to];
    reaching[std::max(edge.from, edge.to)].push_back(edge);
  }
  for (std::size_t i = 1; i < reaching.size(); ++i) {
    auto& list = reaching[i];
    const auto augmentation = std::find_if(list.begin(), list.end(), [&](const PoseEdge& e) { return e.to == i && e.from < i; });
    if (augmentation == list.end())  // the tree gives every neighbour but the oldest an older parent
      throw std::logic_error("marginalizePoses: pose " + std::to_string(out.kept[i]) + " lost its augmentation");
    std::rotate(list.begin(), augmentation, augmentation + 1);
    out.edges.insert(out.edges.end(), list.begin(), list.end());
  }
  return out;
}

}  // namespace llc
