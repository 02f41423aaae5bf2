#include "laser_loop_closure/core/geometry/scan.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace llc {
namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();

bool hasReturn(double range) { return std::isfinite(range) && range > 0.0; }
}  // namespace

ScannerGeometry carmenFlaserGeometry(std::size_t beam_count) {
  ScannerGeometry g;
  g.angle_min = -M_PI / 2.0;
  if (beam_count > 1) {
    const double divisor = (beam_count % 2 == 0) ? double(beam_count) : double(beam_count - 1);
    g.angle_increment = M_PI / divisor;
  }
  return g;
}

Scan scanFromRanges(const std::vector<double>& ranges, const ScannerGeometry& geometry,
                    const Pose2& mount, double stamp) {
  Scan scan;
  scan.stamp = stamp;
  const std::size_t n = ranges.size();
  scan.ranges.resize(n);
  scan.bearings.resize(n);
  const bool identity = mount.x == 0.0 && mount.y == 0.0 && mount.theta == 0.0;
  const double c = std::cos(mount.theta), s = std::sin(mount.theta);
  for (std::size_t i = 0; i < n; ++i) {
    const double beam = geometry.angle_min + double(i) * geometry.angle_increment;
    const double r = ranges[i];
    if (identity) {
      scan.ranges[i] = r;
      scan.bearings[i] = beam;
      continue;
    }
    if (!hasReturn(r)) {  // no point to move: keep the ray's direction in the base frame
      scan.ranges[i] = std::isnan(r) ? r : kInf;
      scan.bearings[i] = normalizeAngle(beam + mount.theta);
      continue;
    }
    const double px = r * std::cos(beam), py = r * std::sin(beam);
    const double bx = mount.x + c * px - s * py, by = mount.y + s * px + c * py;
    scan.ranges[i] = std::hypot(bx, by);
    scan.bearings[i] = std::atan2(by, bx);
  }
  if (!identity) {
    // A moved scanner's bearings are no longer sorted; features walk beams in bearing order.
    std::vector<std::size_t> order(n);
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
      return scan.bearings[a] < scan.bearings[b];
    });
    Scan sorted = scan;
    for (std::size_t i = 0; i < n; ++i) {
      sorted.ranges[i] = scan.ranges[order[i]];
      sorted.bearings[i] = scan.bearings[order[i]];
    }
    scan = std::move(sorted);
  }
  return scan;
}

Scan mergeScans(const Scan& front, const Scan& back, const ScanMergeOptions& options) {
  Scan merged;
  merged.stamp = front.stamp;
  merged.full_circle = true;
  const std::size_t total = front.size() + back.size();
  std::vector<std::pair<double, double>> beams;  // (bearing, range)
  beams.reserve(total);
  for (const Scan* part : {&front, &back})
    for (std::size_t i = 0; i < part->size(); ++i)
      beams.emplace_back(normalizeAngle(part->bearings[i]), part->ranges[i]);
  std::stable_sort(beams.begin(), beams.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  if (options.output_beams == 0) {
    merged.bearings.reserve(total);
    merged.ranges.reserve(total);
    for (const auto& [bearing, range] : beams) {
      merged.bearings.push_back(bearing);
      merged.ranges.push_back(range);
    }
    return merged;
  }
  const std::size_t m = options.output_beams;
  const double step = 2.0 * M_PI / double(m);
  merged.bearings.resize(m);
  merged.ranges.assign(m, kInf);
  for (std::size_t j = 0; j < m; ++j) merged.bearings[j] = -M_PI + (double(j) + 0.5) * step;
  for (const auto& [bearing, range] : beams) {
    if (!hasReturn(range)) continue;
    std::size_t cell = std::size_t(std::floor((bearing + M_PI) / step));
    if (cell >= m) cell = m - 1;
    merged.ranges[cell] = std::min(merged.ranges[cell], range);  // nearest return wins
  }
  return merged;
}

Scan rotateScan(const Scan& scan, double angle) {
  Scan rotated = scan;
  const std::size_t n = scan.size();
  if (n == 0) return rotated;
  if (!scan.full_circle) {
    for (double& b : rotated.bearings) b -= angle;
    return rotated;
  }
  // Full circle: every point turns about the base origin (bearing - angle, wrapped into
  // [-pi, pi)) and the beams are put back in increasing order, a cyclic shift. Exact for any
  // angle and any beam layout, including merged scans whose beams are not evenly spaced.
  std::size_t first = 0;
  for (std::size_t i = 0; i < n; ++i) {
    rotated.bearings[i] = normalizeAngle(scan.bearings[i] - angle);
    if (rotated.bearings[i] < rotated.bearings[first]) first = i;
  }
  std::rotate(rotated.bearings.begin(), rotated.bearings.begin() + long(first), rotated.bearings.end());
  std::rotate(rotated.ranges.begin(), rotated.ranges.begin() + long(first), rotated.ranges.end());
  return rotated;
}

}  // namespace llc
