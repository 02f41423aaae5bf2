// The ESDF's relinearisation policy: which constraints are stale (their linear model misses
// their true error at the current means), and how they are brought up to date (swapped inside
// the factor when few, the whole system rebuilt when many). The factor itself is esdf.cpp's.
#include <algorithm>
#include <cmath>

#include "laser_loop_closure/core/backend/esdf.hpp"
#include "laser_loop_closure/core/geometry/se2_jacobians.hpp"

namespace llc {

Eigen::Vector3d Esdf::currentError(std::size_t k) const {
  // The true error t2v(Z^-1 (A^-1 B)), written out: one sine and cosine per pose.
  const PoseEdge& e = edges_[k];
  const Pose2 &a = mean_[e.from], &b = mean_[e.to];
  const double ca = std::cos(a.theta), sa = std::sin(a.theta);
  const double dx = b.x - a.x, dy = b.y - a.y;
  const double px = ca * dx + sa * dy - e.measurement.x, py = -sa * dx + ca * dy - e.measurement.y;
  const double cz = std::cos(e.measurement.theta), sz = std::sin(e.measurement.theta);
  return {cz * px + sz * py, -sz * px + cz * py, normalizeAngle(b.theta - a.theta - e.measurement.theta)};
}

double Esdf::currentChi2(std::size_t k) const {
  const Eigen::Vector3d error = currentError(k);
  return error.dot(edges_[k].information * error);
}

double Esdf::robustWeight(std::size_t k) const {
  const double w = options_.robust_loop_chi2 * robust_widen_;
  if (!is_loop_[k] || !(w > 0.0)) return 1.0;
  const double chi2 = currentChi2(k);
  if (!(chi2 > w)) return 1.0;
  const double scale = 2.0 * w / (w + chi2);
  // Never exactly 0: the factor's rank updates need a positive definite information.
  return std::max(scale * scale, 1e-9);
}

std::vector<std::size_t> Esdf::reweightedEdges() const {
  std::vector<std::size_t> changed;
  if (!(options_.robust_loop_chi2 > 0.0)) return changed;
  for (std::size_t k = 0; k < edges_.size(); ++k) {
    if (!is_loop_[k]) continue;
    const double now = robustWeight(k), then = weights_[k];
    // A tenth either way: smaller changes move the means by little and would cost a swap each.
    if (std::abs(now - then) > 0.1 * std::max(now, then)) changed.push_back(k);
  }
  return changed;
}

double Esdf::linearizationError(std::size_t k) const {
  const PoseEdge& e = edges_[k];
  const EdgeModel& model = edge_models_[k];
  const Pose2 &a = mean_[e.from], &b = mean_[e.to];
  const Eigen::Vector3d predicted = model.residual + model.ja * poseDifference(a, linearization_[e.from]) +
                                    model.jb * poseDifference(b, linearization_[e.to]);
  Eigen::Vector3d miss = currentError(k) - predicted;
  miss[2] = normalizeAngle(miss[2]);
  return miss.dot(e.information * miss);
}

namespace {
/// a - b wrapped to [-pi, pi): one step, without fmod, for the normalised angles kept here
/// (their difference lies in (-2 pi, 2 pi)); anything else goes through normalizeAngle.
double angleDifference(double a, double b) {
  const double d = a - b;
  if (d >= M_PI && d < 3.0 * M_PI) return d - 2.0 * M_PI;
  if (d < -M_PI && d >= -3.0 * M_PI) return d + 2.0 * M_PI;
  return d >= -M_PI && d < M_PI ? d : normalizeAngle(d);
}
}  // namespace

// The error's only nonlinear part is R(theta_from)^T (t_to - t_from): its angle is linear and
// the outer rotation by Z keeps norms. The first-order model of R(theta)^T v misses by at most
// d^2 / 2 |v| + |d| |dv| (d: the from pose's turn, v: t_to - t_from where linearised, dv: its
// change), since R'' = -R and |R(theta + d) - R(theta)| <= |d|.
double linearizationMissBound(const Pose2& from, const Pose2& to, const Pose2& at_from, const Pose2& at_to,
                              double largest_information) {
  const double turn = std::abs(angleDifference(from.theta, at_from.theta));
  const double vx = at_to.x - at_from.x, vy = at_to.y - at_from.y;
  const double dvx = (to.x - from.x) - vx, dvy = (to.y - from.y) - vy;
  const double miss = 0.5 * turn * turn * std::sqrt(vx * vx + vy * vy) + turn * std::sqrt(dvx * dvx + dvy * dvy);
  return largest_information * miss * miss;
}

std::vector<std::size_t> Esdf::staleEdges(double tau, std::size_t limit) const {
  const double squared_limit = options_.relinearize_translation * options_.relinearize_translation;
  auto moved = [&](const Pose2& now, const Pose2& then) {
    const double dx = now.x - then.x, dy = now.y - then.y;
    return dx * dx + dy * dy > squared_limit ||
           std::abs(angleDifference(now.theta, then.theta)) > options_.relinearize_rotation;
  };
  const std::size_t enough = limit + 1;
  std::vector<std::size_t> stale;
  for (std::size_t k = 0; k < edges_.size() && stale.size() < enough; ++k) {
    const PoseEdge& e = edges_[k];
    const Pose2 &from = mean_[e.from], &to = mean_[e.to];
    if (!moved(from, edge_points_[k].first) && !moved(to, edge_points_[k].second)) continue;
    if (tau > 0.0 && (linearizationMissBound(from, to, edge_points_[k].first, edge_points_[k].second, largest_information_[k]) <= tau ||
                      !(linearizationError(k) > tau)))
      continue;
    stale.push_back(k);
  }
  return stale;
}

bool Esdf::relinearizeInPlace(const std::vector<std::size_t>& stale) {
  // New information in first, old out after, so that the factor stays positive definite.
  // A robust loop takes its weight at the current means with it.
  std::vector<std::pair<Pose2, Pose2>> old_points;
  std::vector<double> old_weights;
  for (const std::size_t k : stale) {
    old_points.push_back(edge_points_[k]);
    old_weights.push_back(weights_[k]);
    addToSystem(k, -1.0);
    edge_points_[k] = {mean_[edges_[k].from], mean_[edges_[k].to]};
    weights_[k] = robustWeight(k);
    addToSystem(k, 1.0);
  }
  auto swapOld = [&] {
    for (std::size_t i = 0; i < stale.size(); ++i)
      std::swap(edge_points_[stale[i]], old_points[i]), std::swap(weights_[stale[i]], old_weights[i]);
  };
  if (!rankUpdate(stale, true)) return false;
  swapOld();
  const bool ok = rankUpdate(stale, false);  // the old information, taken at the old points
  swapOld();
  if (!ok) return false;
  edges_relinearized_in_place_ += int(stale.size());
  return true;
}

int Esdf::relinearizeUntilSteady(bool batch, std::vector<Pose2>* linearization_before) {
  // Batch: Gauss-Newton steps over the whole system while any pose moves past the thresholds.
  const double tau = batch ? 0.0 : options_.relinearize_chi2;
  const std::size_t in_place = batch ? 0 : std::size_t(options_.max_edges_relinearized_in_place);
  int count = 0;
  while (count < options_.max_relinearizations) {
    std::vector<std::size_t> stale = staleEdges(tau, in_place);
    // Robust loops whose weight has moved are swapped like stale ones (they are few).
    for (const std::size_t k : reweightedEdges())
      if (std::find(stale.begin(), stale.end(), k) == stale.end()) stale.push_back(k);
    if (stale.empty()) break;
    ++count;
    ++relinearizations_;
    // A few stale edges are swapped in the factor; many, or a failed downdate, rebuild it all.
    if (stale.size() <= in_place && relinearizeInPlace(stale)) {
      solveMean();
      continue;
    }
    ++rebuilds_;
    if (linearization_before && linearization_before->empty()) *linearization_before = linearization_;
    linearization_ = mean_;
    for (std::size_t k = 0; k < edges_.size(); ++k) weights_[k] = robustWeight(k);
    rebuildSystem();
    factorAndSolve();
  }
  return count;
}

}  // namespace llc
