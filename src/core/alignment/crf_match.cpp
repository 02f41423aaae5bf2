#include "laser_loop_closure/core/alignment/crf_match.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

namespace llc {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kExtentCap = 3.0;         // m; contours longer than this on a side look alike
constexpr double kDistanceCap = 1.0;       // m; a larger mismatch costs no more
constexpr double kMissingPenalty = 0.5;    // one side of a feature exists, the other does not
constexpr std::size_t kScales = kCrfScales.size();
constexpr std::size_t kExtentSlot = 3 * kScales;

/// A contour: points in order with their cumulative arc length.
struct Contour {
  Points2 points;
  std::vector<double> arc;
  double length() const { return arc.back(); }
  Point2 at(double s) const {
    const auto it = std::upper_bound(arc.begin(), arc.end(), s);
    if (it == arc.begin()) return points.front();
    if (it == arc.end()) return points.back();
    const std::size_t k = std::size_t(it - arc.begin());
    const double span = arc[k] - arc[k - 1];
    const double t = span > 0.0 ? (s - arc[k - 1]) / span : 0.0;
    return points[k - 1] + t * (points[k] - points[k - 1]);
  }
};

double featureTerm(double a, double b, double scale) {
  const bool has_a = std::isfinite(a), has_b = std::isfinite(b);
  if (has_a && has_b) return std::min(1.0, std::abs(a - b) / scale);
  return has_a == has_b ? 0.0 : kMissingPenalty;
}
}  // namespace

std::array<double, kCrfWeights> CrfWeights::asArray() const {
  std::array<double, kCrfWeights> values{};
  std::copy(local.begin(), local.end(), values.begin());
  values[kCrfLocalFeatures] = outlier;
  values[kCrfLocalFeatures + 1] = distance;
  values[kCrfLocalFeatures + 2] = order;
  return values;
}

CrfWeights CrfWeights::fromArray(const std::array<double, kCrfWeights>& values) {
  CrfWeights w;
  std::copy(values.begin(), values.begin() + kCrfLocalFeatures, w.local.begin());
  w.outlier = values[kCrfLocalFeatures];
  w.distance = values[kCrfLocalFeatures + 1];
  w.order = values[kCrfLocalFeatures + 2];
  return w;
}

std::string CrfMatchOptions::validate() const {
  if (!(node_spacing > 0.0)) return "node_spacing must be > 0";
  if (max_nodes < 3) return "max_nodes must be >= 3";
  if (!(break_distance > 0.0)) return "break_distance must be > 0";
  if (!(min_contour_length >= 0.0)) return "min_contour_length must be >= 0";
  if (candidates < 1) return "candidates must be >= 1";
  if (!(temperature > 0.0)) return "temperature must be > 0";
  if (!(min_confidence >= 0.0 && min_confidence <= 1.0)) return "min_confidence must be in [0, 1]";
  if (min_associations < 2) return "min_associations must be >= 2";
  for (double w : weights.asArray())
    if (!(w >= 0.0 && std::isfinite(w))) return "weights must be finite and >= 0";
  return fit.validate();
}

CrfScan describeForCrf(const Points2& points, const CrfMatchOptions& options) {
  // Contours: runs of points with no gap wider than break_distance. A point off the current
  // contour whose next point continues it is a stray return (clutter, a mixed pixel) and is
  // skipped rather than breaking the contour.
  std::vector<Contour> contours;
  double total = 0.0;
  auto continues = [&](std::size_t k, std::size_t steps) {
    return !contours.empty() && points[k].allFinite() &&
           (points[k] - contours.back().points.back()).norm() <= options.break_distance * double(steps);
  };
  for (std::size_t k = 0; k < points.size(); ++k) {
    if (!points[k].allFinite()) continue;
    if (!continues(k, 1)) {
      const bool stray = k + 1 < points.size() && continues(k + 1, 2);
      if (stray) continue;
      contours.push_back({{points[k]}, {0.0}});
    } else {
      Contour& c = contours.back();
      c.arc.push_back(c.arc.back() + (points[k] - c.points.back()).norm());
      c.points.push_back(points[k]);
    }
  }
  contours.erase(std::remove_if(contours.begin(), contours.end(),
                                [&](const Contour& c) { return c.length() < options.min_contour_length; }),
                 contours.end());
  for (const Contour& c : contours) total += c.length();
  const double spacing = std::max(options.node_spacing, total / double(options.max_nodes));
  CrfScan scan;
  for (const Contour& c : contours) {
    for (double s = 0.0; s <= c.length() + 1e-12; s += spacing) {
      const Point2 node = c.at(s);
      std::array<double, 3 * kScales + 2> d;
      for (std::size_t k = 0; k < kScales; ++k) {
        const double r = kCrfScales[k];
        const bool before = s - r >= 0.0, after = s + r <= c.length();
        const Point2 p = before ? Point2(c.at(s - r) - node) : Point2::Zero();
        const Point2 q = after ? Point2(c.at(s + r) - node) : Point2::Zero();
        d[3 * k] = before ? p.norm() : kNaN;
        d[3 * k + 1] = after ? q.norm() : kNaN;
        // Signed turn at the node: contours run the same way (increasing bearing) in both
        // scans, so convex and concave corners differ.
        d[3 * k + 2] = before && after ? std::atan2(p.x() * q.y() - p.y() * q.x(), p.dot(q)) : kNaN;
      }
      d[kExtentSlot] = std::min(s, kExtentCap);
      d[kExtentSlot + 1] = std::min(c.length() - s, kExtentCap);
      scan.nodes.push_back(node);
      scan.descriptors.push_back(d);
    }
  }
  return scan;
}

std::array<double, kCrfLocalFeatures> crfLocalFeatures(const CrfScan& source, std::size_t i, const CrfScan& target,
                                                       std::size_t j) {
  const auto& a = source.descriptors[i];
  const auto& b = target.descriptors[j];
  std::array<double, kCrfLocalFeatures> f{};
  for (std::size_t k = 0; k < kScales; ++k) {
    f[k] = 0.5 * (featureTerm(a[3 * k], b[3 * k], kCrfScales[k]) + featureTerm(a[3 * k + 1], b[3 * k + 1], kCrfScales[k]));
    const double x = a[3 * k + 2], y = b[3 * k + 2];
    f[kScales + k] = std::isfinite(x) && std::isfinite(y) ? std::abs(normalizeAngle(x - y)) / M_PI
                                                          : (std::isfinite(x) == std::isfinite(y) ? 0.0 : kMissingPenalty);
  }
  f[2 * kScales] = 0.5 * (std::abs(a[kExtentSlot] - b[kExtentSlot]) + std::abs(a[kExtentSlot + 1] - b[kExtentSlot + 1])) / kExtentCap;
  return f;
}

namespace {
/// Pairwise features of source nodes i, i+1 in target states j, k (both not outliers).
std::array<double, 2> pairwiseFeatures(const CrfScan& source, std::size_t i, const CrfScan& target, long j, long k) {
  const double ds = (source.nodes[i + 1] - source.nodes[i]).norm();
  const double dt = (target.nodes[std::size_t(k)] - target.nodes[std::size_t(j)]).norm();
  const long m = long(target.nodes.size());
  long offset = ((k - j) % m + m) % m;
  if (offset > m / 2) offset -= m;
  return {std::min(std::abs(ds - dt), kDistanceCap) / kDistanceCap, double(std::min(std::labs(offset - 1), 4L)) / 4.0};
}

double logSumExp(const double* values, std::size_t n) {
  double top = -std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < n; ++k) top = std::max(top, values[k]);
  if (!std::isfinite(top)) return top;
  double sum = 0.0;
  for (std::size_t k = 0; k < n; ++k) sum += std::exp(values[k] - top);
  return top + std::log(sum);
}
}  // namespace

CrfMatchResult matchCrf(const CrfScan& source, const CrfScan& target, const CrfMatchOptions& options,
                        const std::vector<long>* forced) {
  const auto start = std::chrono::steady_clock::now();
  CrfMatchResult result;
  auto finish = [&](const char* reason) {
    result.reject_reason = reason;
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
  };
  const std::size_t n = source.nodes.size(), m = target.nodes.size();
  if (n < options.min_associations || m < options.min_associations) return finish("too few contour nodes");
  const CrfWeights& w = options.weights;
  const std::size_t kept = std::min(options.candidates, m);
  const std::size_t states = kept + 1;  // the last state is "outlier"
  // Candidate states per node: the targets with the lowest local energy.
  std::vector<long> candidate(n * states, -1);
  std::vector<double> unary(n * states);
  std::vector<std::pair<double, long>> scored(m);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = 0; j < m; ++j) {
      const auto f = crfLocalFeatures(source, i, target, j);
      double e = 0.0;
      for (std::size_t q = 0; q < kCrfLocalFeatures; ++q) e += w.local[q] * f[q];
      scored[j] = {e, long(j)};
    }
    std::partial_sort(scored.begin(), scored.begin() + long(kept), scored.end());
    if (forced && (*forced)[i] >= 0) {
      const long want = (*forced)[i];
      if (std::none_of(scored.begin(), scored.begin() + long(kept), [&](const auto& s) { return s.second == want; })) {
        const auto f = crfLocalFeatures(source, i, target, std::size_t(want));
        double e = 0.0;
        for (std::size_t q = 0; q < kCrfLocalFeatures; ++q) e += w.local[q] * f[q];
        scored[kept - 1] = {e, want};
      }
    }
    for (std::size_t s = 0; s < kept; ++s) candidate[i * states + s] = scored[s].second, unary[i * states + s] = scored[s].first;
    unary[i * states + kept] = w.outlier;
  }
  // Pairwise energies between the candidates of consecutive nodes.
  auto pairwise = [&](std::size_t i, std::size_t s, std::size_t t) {
    const long j = candidate[i * states + s], k = candidate[(i + 1) * states + t];
    if (j < 0 || k < 0) return 0.0;
    const auto f = pairwiseFeatures(source, i, target, j, k);
    return w.distance * f[0] + w.order * f[1];
  };
  std::vector<double> edge((n - 1) * states * states);
  for (std::size_t i = 0; i + 1 < n; ++i)
    for (std::size_t s = 0; s < states; ++s)
      for (std::size_t t = 0; t < states; ++t) edge[(i * states + s) * states + t] = pairwise(i, s, t);
  auto edgeAt = [&](std::size_t i, std::size_t s, std::size_t t) { return edge[(i * states + s) * states + t]; };
  // Max-product (min-sum on energies): exact MAP on a chain.
  std::vector<double> best(n * states);
  std::vector<std::size_t> back(n * states, 0);
  for (std::size_t s = 0; s < states; ++s) best[s] = unary[s];
  for (std::size_t i = 1; i < n; ++i)
    for (std::size_t t = 0; t < states; ++t) {
      double low = std::numeric_limits<double>::infinity();
      std::size_t arg = 0;
      for (std::size_t s = 0; s < states; ++s) {
        const double e = best[(i - 1) * states + s] + edgeAt(i - 1, s, t);
        if (e < low) low = e, arg = s;
      }
      best[i * states + t] = low + unary[i * states + t];
      back[i * states + t] = arg;
    }
  std::vector<std::size_t> map_state(n);
  map_state[n - 1] = std::size_t(std::min_element(best.begin() + long((n - 1) * states), best.end()) -
                                 (best.begin() + long((n - 1) * states)));
  for (std::size_t i = n - 1; i > 0; --i) map_state[i - 1] = back[i * states + map_state[i]];
  // Sum-product in the log domain: marginals of every state.
  const double inv_t = 1.0 / options.temperature;
  std::vector<double> alpha(n * states), beta(n * states, 0.0), terms(states);
  for (std::size_t s = 0; s < states; ++s) alpha[s] = -unary[s] * inv_t;
  for (std::size_t i = 1; i < n; ++i)
    for (std::size_t t = 0; t < states; ++t) {
      for (std::size_t s = 0; s < states; ++s) terms[s] = alpha[(i - 1) * states + s] - edgeAt(i - 1, s, t) * inv_t;
      alpha[i * states + t] = logSumExp(terms.data(), states) - unary[i * states + t] * inv_t;
    }
  for (std::size_t i = n - 1; i > 0; --i)
    for (std::size_t s = 0; s < states; ++s) {
      for (std::size_t t = 0; t < states; ++t)
        terms[t] = beta[i * states + t] - (edgeAt(i - 1, s, t) + unary[i * states + t]) * inv_t;
      beta[(i - 1) * states + s] = logSumExp(terms.data(), states);
    }
  const double log_z = logSumExp(alpha.data() + (n - 1) * states, states);
  result.association.assign(n, -1);
  result.confidence.assign(n, 0.0);
  std::vector<Correspondence2> correspondences;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t s = map_state[i];
    result.association[i] = candidate[i * states + s];
    result.confidence[i] = std::exp(alpha[i * states + s] + beta[i * states + s] - log_z);
    if (result.association[i] >= 0 && result.confidence[i] >= options.min_confidence)
      correspondences.push_back({source.nodes[i], target.nodes[std::size_t(result.association[i])], result.confidence[i]});
  }
  result.confident = correspondences.size();
  if (correspondences.size() < options.min_associations) return finish("too few confident associations");
  const RobustFitResult fit = fitRigidRobust(correspondences, options.fit);
  result.inliers = fit.inlier_count;
  if (!fit.ok || fit.inlier_count < options.min_associations) return finish("associations agree on no transform");
  result.ok = true;
  result.pose = fit.pose;
  result.alternatives = fit.alternatives;
  return finish("");
}

std::array<double, kCrfWeights> crfFeatureTotals(const CrfScan& source, const CrfScan& target,
                                                  const std::vector<long>& association) {
  std::array<double, kCrfWeights> totals{};
  for (std::size_t i = 0; i < association.size(); ++i) {
    if (association[i] < 0) {
      totals[kCrfLocalFeatures] += 1.0;
      continue;
    }
    const auto f = crfLocalFeatures(source, i, target, std::size_t(association[i]));
    for (std::size_t q = 0; q < kCrfLocalFeatures; ++q) totals[q] += f[q];
    if (i + 1 < association.size() && association[i + 1] >= 0) {
      const auto p = pairwiseFeatures(source, i, target, association[i], association[i + 1]);
      totals[kCrfLocalFeatures + 1] += p[0];
      totals[kCrfLocalFeatures + 2] += p[1];
    }
  }
  return totals;
}

std::vector<long> crfTrueAssociation(const CrfScan& source, const CrfScan& target, const Pose2& pose,
                                     double max_distance) {
  std::vector<long> association(source.nodes.size(), -1);
  if (target.nodes.empty()) return association;
  const KdTree2 tree(target.nodes);
  for (std::size_t i = 0; i < source.nodes.size(); ++i) {
    std::size_t index;
    double distance_sq;
    if (tree.nearest(transformPoint(pose, source.nodes[i]), &index, &distance_sq, max_distance * max_distance) && distance_sq <= max_distance * max_distance)
      association[i] = long(index);
  }
  return association;
}

}  // namespace llc
