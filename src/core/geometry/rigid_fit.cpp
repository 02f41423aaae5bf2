#include "laser_loop_closure/core/geometry/rigid_fit.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "laser_loop_closure/core/common/random.hpp"

namespace llc {

bool fitRigid(const std::vector<Correspondence2>& correspondences, Pose2* pose) {
  double total = 0.0;
  Point2 mean_source = Point2::Zero(), mean_target = Point2::Zero();
  for (const Correspondence2& c : correspondences) {
    if (!(c.weight > 0.0)) continue;
    total += c.weight;
    mean_source += c.weight * c.source;
    mean_target += c.weight * c.target;
  }
  if (!(total > 0.0)) return false;
  mean_source /= total;
  mean_target /= total;
  // The rotation angle maximising sum w (R s) . t over centred points: atan2 of the summed
  // cross and dot products.
  double dot = 0.0, cross = 0.0, spread = 0.0;
  for (const Correspondence2& c : correspondences) {
    if (!(c.weight > 0.0)) continue;
    const Point2 s = c.source - mean_source, t = c.target - mean_target;
    dot += c.weight * s.dot(t);
    cross += c.weight * (s.x() * t.y() - s.y() * t.x());
    spread += c.weight * s.squaredNorm();
  }
  if (!(spread > 1e-12 * total) || !std::isfinite(dot + cross)) return false;
  const double theta = std::atan2(cross, dot);
  const double co = std::cos(theta), si = std::sin(theta);
  pose->theta = normalizeAngle(theta);
  pose->x = mean_target.x() - (co * mean_source.x() - si * mean_source.y());
  pose->y = mean_target.y() - (si * mean_source.x() + co * mean_source.y());
  return true;
}

std::string RobustFitOptions::validate() const {
  if (!(inlier_distance > 0.0)) return "inlier_distance must be > 0";
  if (hypotheses < 1) return "hypotheses must be >= 1";
  if (alternatives < 0) return "alternatives must be >= 0";
  if (!(distinct_distance >= 0.0) || !(distinct_angle >= 0.0)) return "distinct_distance and distinct_angle must be >= 0";
  return "";
}

namespace {
double markInliers(const std::vector<Correspondence2>& cs, const Pose2& pose, double limit_sq,
                   std::vector<char>* inlier, std::size_t* count) {
  double weight = 0.0;
  *count = 0;
  const RigidMotion2 motion(pose);
  for (std::size_t i = 0; i < cs.size(); ++i) {
    const bool in = cs[i].weight > 0.0 && (motion(cs[i].source) - cs[i].target).squaredNorm() <= limit_sq;
    (*inlier)[i] = in;
    if (in) weight += cs[i].weight, ++*count;
  }
  return weight;
}
}  // namespace

namespace {
/// Weighted least squares on the inliers of `pose`, repeated until the inlier set is stable.
RobustFitResult refine(const std::vector<Correspondence2>& cs, Pose2 pose, double limit_sq) {
  RobustFitResult result;
  std::vector<char> inlier(cs.size());
  std::size_t count = 0;
  for (int round = 0; round < 10; ++round) {
    const double weight = markInliers(cs, pose, limit_sq, &inlier, &count);
    if (count < 2) break;
    const bool same = result.ok && inlier == result.inlier;
    result.ok = true;
    result.pose = pose;
    result.inlier = inlier;
    result.inlier_weight = weight;
    result.inlier_count = count;
    if (same) break;
    std::vector<Correspondence2> chosen;
    for (std::size_t i = 0; i < cs.size(); ++i)
      if (inlier[i]) chosen.push_back(cs[i]);
    if (!fitRigid(chosen, &pose)) break;
  }
  return result;
}
}  // namespace

RobustFitResult fitRigidRobust(const std::vector<Correspondence2>& cs, const RobustFitOptions& options) {
  RobustFitResult result;
  result.inlier.assign(cs.size(), 0);
  std::vector<std::size_t> usable;
  for (std::size_t i = 0; i < cs.size(); ++i)
    if (cs[i].weight > 0.0) usable.push_back(i);
  if (usable.size() < 2) return result;
  const double limit_sq = options.inlier_distance * options.inlier_distance;
  Random random(options.seed);
  std::vector<char> inlier(cs.size());
  std::vector<std::pair<double, Pose2>> hypotheses;
  std::size_t count = 0;
  for (int h = 0; h < options.hypotheses; ++h) {
    const std::size_t i = usable[random.index(usable.size())];
    const std::size_t j = usable[random.index(usable.size())];
    // Two associations fix a rigid transform only if they agree on the distance they span.
    const double ds = (cs[i].source - cs[j].source).norm(), dt = (cs[i].target - cs[j].target).norm();
    if (i == j || ds < 2.0 * options.inlier_distance || std::abs(ds - dt) > options.inlier_distance) continue;
    Pose2 pose;
    if (!fitRigid({Correspondence2{cs[i].source, cs[i].target, 1.0}, Correspondence2{cs[j].source, cs[j].target, 1.0}}, &pose))
      continue;
    hypotheses.push_back({markInliers(cs, pose, limit_sq, &inlier, &count), pose});
  }
  std::stable_sort(hypotheses.begin(), hypotheses.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<RobustFitResult> kept;
  auto distinct = [&](const Pose2& pose) {
    for (const RobustFitResult& k : kept)
      if (std::hypot(k.pose.x - pose.x, k.pose.y - pose.y) <= options.distinct_distance &&
          std::abs(normalizeAngle(k.pose.theta - pose.theta)) <= options.distinct_angle)
        return false;
    return true;
  };
  for (const auto& [weight, pose] : hypotheses) {
    if (weight <= 0.0 || kept.size() > std::size_t(options.alternatives)) break;
    if (!distinct(pose)) continue;
    RobustFitResult refined = refine(cs, pose, limit_sq);
    if (refined.ok && distinct(refined.pose)) kept.push_back(std::move(refined));
  }
  if (kept.empty()) return result;
  // The refits may reorder them: best inlier weight first.
  std::stable_sort(kept.begin(), kept.end(),
                   [](const RobustFitResult& a, const RobustFitResult& b) { return a.inlier_weight > b.inlier_weight; });
  result = kept.front();
  for (std::size_t k = 1; k < kept.size(); ++k) result.alternatives.push_back(kept[k].pose);
  return result;
}

}  // namespace llc
