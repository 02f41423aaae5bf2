#include "laser_loop_closure/core/slam/localization_evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_map>

namespace llc {

Pose2 whereTheMapHasIt(const MapWithTruth& map, const Pose2& truth, double* nearest_m) {
  std::size_t nearest = 0;
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t m = 0; m < map.truth.size() && m < map.poses.size(); ++m) {
    const double d = std::hypot(map.truth[m].x - truth.x, map.truth[m].y - truth.y);
    if (d < best) best = d, nearest = m;
  }
  if (nearest_m) *nearest_m = best;
  return std::isfinite(best) ? compose(map.poses[nearest], between(map.truth[nearest], truth))
                             : compose(inverse(map.truth_from_map), truth);
}

ScanError scanError(const LocalizedScan& scan, const MapWithTruth& map) {
  ScanError e;
  e.against_map = between(whereTheMapHasIt(map, scan.truth, &e.nearest_map_keyframe_m), scan.pose);
  e.against_truth = between(scan.truth, compose(map.truth_from_map, scan.pose));
  return e;
}

bool wrongPose(const Pose2& error, double wrong_translation, double wrong_rotation) {
  return !(std::hypot(error.x, error.y) <= wrong_translation && std::abs(normalizeAngle(error.theta)) <= wrong_rotation);
}

LocalizationScore scoreLocalization(const std::vector<LocalizedScan>& scans, const MapWithTruth& map,
                                    double wrong_translation, double wrong_rotation, double judge_within) {
  LocalizationScore score;
  auto wrong = [&](const Pose2& e) { return wrongPose(e, wrong_translation, wrong_rotation); };
  double sum = 0.0, sum_global = 0.0;
  for (const LocalizedScan& s : scans) {
    if (!s.localized) continue;
    const ScanError e = scanError(s, map);
    if (std::isfinite(e.nearest_map_keyframe_m) && e.nearest_map_keyframe_m > judge_within) {
      ++score.beyond_map;
      continue;
    }
    const Pose2& error = e.against_map;
    const Pose2& global = e.against_truth;
    const double metres = std::hypot(error.x, error.y), global_metres = std::hypot(global.x, global.y);
    ++score.localized;
    sum += metres * metres;
    sum_global += global_metres * global_metres;
    score.max_m = std::max(score.max_m, metres);
    score.wrong_poses += wrong(error);
    score.wrong_poses_contradicted += wrong(error) && s.reference_contradicted;
    score.wrong_poses_global += wrong(global);
    if (s.fixed) {
      ++score.fixes;
      score.wrong_fixes += wrong(error);
      score.wrong_fixes_contradicted += wrong(error) && s.reference_contradicted;
      score.wrong_fixes_global += wrong(global);
    }
  }
  if (score.localized > 0) {
    score.rms_m = std::sqrt(sum / double(score.localized));
    score.rms_global_m = std::sqrt(sum_global / double(score.localized));
  }
  return score;
}

std::vector<bool> startsNearMap(const std::vector<Pose2>& truth, const std::vector<Pose2>& mapped, double travel, double radius,
                                double max_heading) {
  // Mapped positions in cells of `radius`: a query looks at its cell and the eight around it.
  auto cell = [&](double x, double y) {
    return std::pair<std::int64_t, std::int64_t>{std::int64_t(std::floor(x / radius)), std::int64_t(std::floor(y / radius))};
  };
  auto key = [](std::int64_t i, std::int64_t j) { return std::uint64_t(i) * 0x9E3779B97F4A7C15ULL ^ std::uint64_t(j); };
  std::unordered_multimap<std::uint64_t, std::size_t> grid;
  for (std::size_t m = 0; m < mapped.size(); ++m) {
    if (!isFinite(mapped[m])) continue;
    const auto [i, j] = cell(mapped[m].x, mapped[m].y);
    grid.emplace(key(i, j), m);
  }
  std::vector<bool> near(truth.size(), false);
  for (std::size_t s = 0; s < truth.size(); ++s) {
    if (!isFinite(truth[s])) continue;
    const auto [i, j] = cell(truth[s].x, truth[s].y);
    for (std::int64_t di = -1; di <= 1 && !near[s]; ++di)
      for (std::int64_t dj = -1; dj <= 1 && !near[s]; ++dj) {
        const auto range = grid.equal_range(key(i + di, j + dj));
        for (auto it = range.first; it != range.second; ++it)
          if (std::hypot(mapped[it->second].x - truth[s].x, mapped[it->second].y - truth[s].y) <= radius &&
              std::abs(normalizeAngle(mapped[it->second].theta - truth[s].theta)) <= max_heading) {
            near[s] = true;
            break;
          }
      }
  }
  // A start is good when a scan within its first `travel` m is near the map.
  std::vector<bool> starts(truth.size(), false);
  for (std::size_t s = 0; s < truth.size(); ++s) {
    double path = 0.0;
    for (std::size_t k = s; k < truth.size() && path <= travel; ++k) {
      if (k > s) path += std::hypot(truth[k].x - truth[k - 1].x, truth[k].y - truth[k - 1].y);
      if (path <= travel && near[k]) {
        starts[s] = true;
        break;
      }
    }
  }
  return starts;
}

}  // namespace llc
