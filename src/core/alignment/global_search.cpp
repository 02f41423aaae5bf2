#include "laser_loop_closure/core/alignment/global_search.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace llc {

std::string GlobalSearchOptions::validate() const {
  if (!(sample_spacing >= 0.0)) return "sample_spacing must be >= 0";
  if (!(angle_bin > 0.0 && angle_bin <= M_PI / 4)) return "angle_bin must be in (0, pi/4]";
  if (rotations < 1) return "rotations must be >= 1";
  if (!(cell > 0.0)) return "cell must be > 0";
  if (!(max_translation >= cell && max_translation / cell <= 2000.0))
    return "max_translation must be at least one cell and at most 2000 cells";
  if (!(max_normal_angle > 0.0 && max_normal_angle <= M_PI / 2)) return "max_normal_angle must be in (0, pi/2]";
  if (hypotheses < 1) return "hypotheses must be >= 1";
  if (!(distinct_distance >= 0.0)) return "distinct_distance must be >= 0";
  return "";
}

namespace {

/// Histogram of the normal directions over `bins` bins of [-pi, pi), each normal shared
/// between its two nearest bin centres so that a small turn changes the histogram smoothly.
std::vector<double> orientationHistogram(const std::vector<double>& angles, std::size_t bins) {
  std::vector<double> histogram(bins, 0.0);
  const double width = 2.0 * M_PI / double(bins);
  for (const double angle : angles) {
    const double u = (angle + M_PI) / width - 0.5;
    const double lower = std::floor(u);
    const double f = u - lower;
    const long k = long(lower);
    const long n = long(bins);
    histogram[std::size_t(((k % n) + n) % n)] += 1.0 - f;
    histogram[std::size_t((((k + 1) % n) + n) % n)] += f;
  }
  return histogram;
}

/// Rotations (rad) at the highest local maxima of the circular correlation of the two
/// histograms, best first, each refined between bins by a parabola through its neighbours.
std::vector<double> likelyRotations(const std::vector<double>& a, const std::vector<double>& b, int count) {
  const std::size_t n = a.size();
  std::vector<double> correlation(n, 0.0);
  for (std::size_t shift = 0; shift < n; ++shift) {
    double sum = 0.0;
    for (std::size_t j = 0; j < n; ++j) sum += a[(j + shift) % n] * b[j];
    correlation[shift] = sum;  // b turned by shift bins lies on a
  }
  std::vector<std::pair<double, double>> peaks;  // (correlation, rotation)
  const double width = 2.0 * M_PI / double(n);
  for (std::size_t s = 0; s < n; ++s) {
    const double left = correlation[(s + n - 1) % n], centre = correlation[s], right = correlation[(s + 1) % n];
    if (!(centre > left && centre >= right)) continue;
    const double curvature = left - 2.0 * centre + right;
    const double offset = curvature < 0.0 ? 0.5 * (left - right) / curvature : 0.0;
    peaks.emplace_back(centre, normalizeAngle((double(s) + offset) * width));
  }
  std::sort(peaks.begin(), peaks.end(), [](const auto& x, const auto& y) { return x.first > y.first; });
  std::vector<double> rotations;
  for (std::size_t k = 0; k < peaks.size() && int(k) < count; ++k) rotations.push_back(peaks[k].second);
  return rotations;
}

struct Candidate {
  double votes;
  Pose2 pose;
};

/// Hough voting for the translation of b (already turned by `rotation`) onto a: every pair of
/// points whose normals agree within max_normal_angle votes for the translation that puts
/// them together. Returns the distinct peaks of the vote grid summed over 3 x 3 cells.
std::vector<Candidate> voteTranslations(const GlobalSearchScan& a, const GlobalSearchScan& b, double rotation,
                                        const GlobalSearchOptions& options) {
  const RigidMotion2 turn(Pose2{0.0, 0.0, rotation});
  // b's points and normals turned, bucketed by normal direction: buckets at least
  // max_normal_angle wide, so a normal's partners lie in its own bucket or the two beside it.
  const std::size_t bucket_count = std::max<std::size_t>(3, std::size_t(2.0 * M_PI / options.max_normal_angle));
  const double bucket_width = 2.0 * M_PI / double(bucket_count);
  auto bucketOf = [&](double angle) {
    return std::min(bucket_count - 1, std::size_t(std::max(0.0, (angle + M_PI) / bucket_width)));
  };
  std::vector<std::vector<std::size_t>> buckets(bucket_count);
  Points2 turned(b.points.size()), turned_normals(b.points.size());
  for (std::size_t j = 0; j < b.points.size(); ++j) {
    turned[j] = turn(b.points[j]);
    const double angle = normalizeAngle(b.normal_angles[j] + rotation);
    turned_normals[j] = Point2(std::cos(angle), std::sin(angle));
    buckets[bucketOf(angle)].push_back(j);
  }
  const double min_cos = std::cos(options.max_normal_angle);
  const long side = long(std::ceil(2.0 * options.max_translation / options.cell));
  std::vector<float> grid(std::size_t(side * side), 0.0f);
  const double origin = -0.5 * double(side) * options.cell;
  for (std::size_t i = 0; i < a.points.size(); ++i) {
    const std::size_t home = bucketOf(a.normal_angles[i]);
    const Point2 normal(std::cos(a.normal_angles[i]), std::sin(a.normal_angles[i]));
    for (const std::size_t bucket : {(home + bucket_count - 1) % bucket_count, home, (home + 1) % bucket_count}) {
      for (const std::size_t j : buckets[bucket]) {
        if (normal.dot(turned_normals[j]) < min_cos) continue;  // surfaces facing apart
        const long ix = long(std::floor((a.points[i].x() - turned[j].x() - origin) / options.cell));
        const long iy = long(std::floor((a.points[i].y() - turned[j].y() - origin) / options.cell));
        if (ix < 0 || iy < 0 || ix >= side || iy >= side) continue;
        grid[std::size_t(iy * side + ix)] += 1.0f;
      }
    }
  }
  // Peaks of the 3 x 3 sums (a vote lands in one of four cells around the true translation),
  // taken only at cells with votes of their own; the translation is the vote-weighted mean of
  // the nine cells' centres.
  std::vector<Candidate> peaks;
  auto cellAt = [&](long x, long y) { return x < 0 || y < 0 || x >= side || y >= side ? 0.0 : double(grid[std::size_t(y * side + x)]); };
  std::vector<double> summed(grid.size(), 0.0);
  for (long y = 0; y < side; ++y)
    for (long x = 0; x < side; ++x) {
      if (grid[std::size_t(y * side + x)] == 0.0f) continue;
      double sum = 0.0;
      for (long dy = -1; dy <= 1; ++dy)
        for (long dx = -1; dx <= 1; ++dx) sum += cellAt(x + dx, y + dy);
      summed[std::size_t(y * side + x)] = sum;
    }
  auto summedAt = [&](long x, long y) { return x < 0 || y < 0 || x >= side || y >= side ? 0.0 : summed[std::size_t(y * side + x)]; };
  for (long y = 0; y < side; ++y)
    for (long x = 0; x < side; ++x) {
      const double centre = summedAt(x, y);
      if (centre <= 0.0) continue;
      bool peak = true;
      for (long dy = -1; dy <= 1 && peak; ++dy)
        for (long dx = -1; dx <= 1; ++dx) {
          if (dx == 0 && dy == 0) continue;
          const double other = summedAt(x + dx, y + dy);
          // Ties go to the first cell in scan order, so a flat top gives one peak.
          if (other > centre || (other == centre && (dy < 0 || (dy == 0 && dx < 0)))) {
            peak = false;
            break;
          }
        }
      if (!peak) continue;
      double wx = 0.0, wy = 0.0;
      for (long dy = -1; dy <= 1; ++dy)
        for (long dx = -1; dx <= 1; ++dx) {
          const double w = cellAt(x + dx, y + dy);
          wx += w * (origin + (double(x + dx) + 0.5) * options.cell);
          wy += w * (origin + (double(y + dy) + 0.5) * options.cell);
        }
      peaks.push_back({centre, Pose2{wx / centre, wy / centre, rotation}});
    }
  std::sort(peaks.begin(), peaks.end(), [](const Candidate& x, const Candidate& y) { return x.votes > y.votes; });
  std::vector<Candidate> distinct;
  for (const Candidate& candidate : peaks) {
    if (int(distinct.size()) >= options.hypotheses) break;
    const bool near_better = std::any_of(distinct.begin(), distinct.end(), [&](const Candidate& d) {
      return std::hypot(d.pose.x - candidate.pose.x, d.pose.y - candidate.pose.y) < options.distinct_distance;
    });
    if (!near_better) distinct.push_back(candidate);
  }
  return distinct;
}

}  // namespace

GlobalSearchScan describeForGlobalSearch(const Points2& points, const Points2& normals, const GlobalSearchOptions& options) {
  GlobalSearchScan scan;
  const double min_squared = options.sample_spacing * options.sample_spacing;
  for (std::size_t i = 0; i < points.size() && i < normals.size(); ++i) {
    Point2 normal = normals[i];
    if (!(normal.squaredNorm() > 0.5) || !points[i].allFinite()) continue;  // no surface here
    if (!scan.points.empty() && (points[i] - scan.points.back()).squaredNorm() < min_squared) continue;
    if (normal.dot(points[i]) > 0.0) normal = -normal;  // towards the scanner
    scan.points.push_back(points[i]);
    scan.normal_angles.push_back(std::atan2(normal.y(), normal.x()));
  }
  return scan;
}

GlobalSearchResult searchGlobally(const GlobalSearchScan& a, const GlobalSearchScan& b, const GlobalSearchOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  GlobalSearchResult result;
  if (a.points.size() < 3 || b.points.size() < 3) {
    result.reject_reason = "fewer than 3 points with a surface";
    return result;
  }
  const std::size_t bins = std::max<std::size_t>(8, std::size_t(std::lround(2.0 * M_PI / options.angle_bin)));
  const std::vector<double> rotations =
      likelyRotations(orientationHistogram(a.normal_angles, bins), orientationHistogram(b.normal_angles, bins), options.rotations);
  std::vector<Candidate> all;
  for (const double rotation : rotations) {
    const std::vector<Candidate> found = voteTranslations(a, b, rotation, options);
    all.insert(all.end(), found.begin(), found.end());
  }
  std::stable_sort(all.begin(), all.end(), [](const Candidate& x, const Candidate& y) { return x.votes > y.votes; });
  for (std::size_t k = 0; k < all.size() && int(k) < options.hypotheses; ++k) {
    result.poses.push_back(all[k].pose);
    result.votes.push_back(all[k].votes);
  }
  if (result.poses.empty()) result.reject_reason = "no pair of points voted for a translation in range";
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace llc
