#include "laser_loop_closure/core/geometry/relation_error.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <utility>

namespace llc {
namespace {

double sampleStd(const std::vector<double>& values, double mean) {
  if (values.size() < 2) return 0.0;
  double sum = 0.0;
  for (double v : values) sum += (v - mean) * (v - mean);
  return std::sqrt(sum / double(values.size() - 1));
}

}  // namespace

StampIndex::StampIndex(std::vector<double> stamps) : stamps_(std::move(stamps)), order_(stamps_.size()) {
  std::iota(order_.begin(), order_.end(), std::size_t(0));
  std::stable_sort(order_.begin(), order_.end(), [&](std::size_t a, std::size_t b) { return stamps_[a] < stamps_[b]; });
}

std::optional<std::size_t> StampIndex::find(double t, double tolerance) const {
  const auto it = std::lower_bound(order_.begin(), order_.end(), t, [&](std::size_t i, double v) { return stamps_[i] < v; });
  std::optional<std::size_t> best;
  double best_gap = tolerance;
  for (auto candidate : {it, it == order_.begin() ? it : it - 1}) {
    if (candidate == order_.end()) continue;
    const double gap = std::abs(stamps_[*candidate] - t);
    if (gap <= best_gap) best = *candidate, best_gap = gap;
  }
  return best;
}

RelationErrorResult evaluateRelations(const std::vector<Relation>& relations, const ScanTrack& track,
                                      const RelationErrorOptions& options) {
  const std::size_t n = track.stamps.size();
  if (track.odometry.size() != n || track.poses.size() != n || (!track.scanner_mounts.empty() && track.scanner_mounts.size() != n))
    throw std::invalid_argument("relations: the track's stamps, odometry, poses and scanner mounts differ in count");
  RelationErrorResult result;
  result.relations = relations.size();
  // For each scan the nearest scan (in log order) with a pose of its own: earlier or later.
  std::vector<std::size_t> previous(n, n), next(n, n);
  for (std::size_t i = 0, last = n; i < n; ++i) previous[i] = last = track.poses[i] ? i : last;
  for (std::size_t i = n, last = n; i-- > 0;) next[i] = last = track.poses[i] ? i : last;
  auto poseOf = [&](std::size_t i, bool* carried) -> std::optional<Pose2> {
    if (track.poses[i]) return track.poses[i];
    const std::size_t a = previous[i], b = next[i];
    if (a == n && b == n) return std::nullopt;
    const std::size_t from = b == n || (a != n && i - a <= b - i) ? a : b;
    *carried = true;
    return compose(*track.poses[from], between(track.odometry[from], track.odometry[i]));
  };
  const StampIndex index(track.stamps);
  std::vector<double> translations, rotations;
  for (std::size_t r = 0; r < relations.size(); ++r) {
    const auto s1 = index.find(relations[r].t1, options.stamp_tolerance);
    const auto s2 = index.find(relations[r].t2, options.stamp_tolerance);
    if (!s1 || !s2) {
      ++result.unmatched;
      continue;
    }
    RelationError e;
    e.relation = r, e.scan1 = *s1, e.scan2 = *s2;
    const auto p1 = poseOf(*s1, &e.carried), p2 = poseOf(*s2, &e.carried);
    if (!p1 || !p2) continue;
    const Pose2 estimated = track.scanner_mounts.empty()
                                ? between(*p1, *p2)
                                : between(compose(*p1, track.scanner_mounts[*s1]), compose(*p2, track.scanner_mounts[*s2]));
    const Pose2& truth = relations[r].motion;
    e.translation = std::hypot(estimated.x - truth.x, estimated.y - truth.y);
    e.rotation = std::abs(normalizeAngle(estimated.theta - truth.theta));
    result.carried += e.carried;
    translations.push_back(e.translation);
    rotations.push_back(e.rotation);
    result.errors.push_back(e);
  }
  result.evaluated = result.errors.size();
  if (result.evaluated > 0) {
    const double count = double(result.evaluated);
    result.translation_mean = std::accumulate(translations.begin(), translations.end(), 0.0) / count;
    result.rotation_mean = std::accumulate(rotations.begin(), rotations.end(), 0.0) / count;
    result.translation_std = sampleStd(translations, result.translation_mean);
    result.rotation_std = sampleStd(rotations, result.rotation_mean);
    result.translation_max = *std::max_element(translations.begin(), translations.end());
    result.rotation_max = *std::max_element(rotations.begin(), rotations.end());
  }
  return result;
}

}  // namespace llc
