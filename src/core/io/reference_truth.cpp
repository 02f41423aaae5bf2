#include "laser_loop_closure/core/io/reference_truth.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <stdexcept>
#include <vector>

namespace llc {
namespace {

/// What names a scan across logs: the ranges as recorded when the reader kept them, else
/// the scan's own (the same when the scanner sits at the base origin).
std::uint64_t scanKey(const LoggedScan& s) {
  return s.recorded_ranges_key != 0 ? s.recorded_ranges_key : recordedRangesKey(s.scan.ranges);
}

/// The odometry the truth is carried by: each scan's, except where the odometry's source
/// stalled (a reading repeated exactly, then a different one within kMaxStall seconds: MIT
/// CSAIL's wheels report nothing for 1 s mid-turn, then jump 0.87 rad). There the readings
/// are interpolated in time from the last reading before the run to the first one after it.
std::vector<Pose2> odometryWithoutStalls(const ScanSequence& sequence, std::size_t* stalled) {
  constexpr double kMaxStall = 2.0;  // s
  const std::vector<LoggedScan>& scans = sequence.scans;
  std::vector<Pose2> odometry(scans.size());
  for (std::size_t i = 0; i < scans.size(); ++i) odometry[i] = scans[i].odometry;
  auto same = [](const Pose2& a, const Pose2& b) { return a.x == b.x && a.y == b.y && a.theta == b.theta; };
  for (std::size_t i = 1; i < scans.size(); ++i) {
    if (!same(odometry[i], odometry[i - 1])) continue;
    std::size_t next = i;  // the first reading after the run
    while (next < scans.size() && same(odometry[next], odometry[i - 1])) ++next;
    const double t0 = scans[i - 1].stamp;
    if (next == scans.size() || !(scans[next].stamp > t0) || scans[next].stamp - t0 > kMaxStall) {
      i = next;
      continue;
    }
    const Pose2 step = between(odometry[i - 1], odometry[next]);
    for (std::size_t k = i; k < next; ++k) {
      const double w = std::clamp((scans[k].stamp - t0) / (scans[next].stamp - t0), 0.0, 1.0);
      odometry[k] = compose(odometry[i - 1], Pose2{w * step.x, w * step.y, w * step.theta});
      ++*stalled;
    }
    i = next;
  }
  return odometry;
}

}  // namespace

ReferenceTruthResult applyReferenceTruth(const ScanSequence& reference, ScanSequence* sequence) {
  ReferenceTruthResult result;
  // Each key's scans in the sequence: a key met twice cannot say which scan is meant.
  std::map<std::uint64_t, std::vector<std::size_t>> by_ranges;
  for (std::size_t i = 0; i < sequence->scans.size(); ++i) by_ranges[scanKey(sequence->scans[i])].push_back(i);
  std::map<std::uint64_t, std::size_t> reference_count;
  for (const LoggedScan& r : reference.scans) ++reference_count[scanKey(r)];
  constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
  std::vector<std::size_t> source(sequence->scans.size(), kNone);  // the reference scan each matched scan takes
  for (std::size_t j = 0; j < reference.scans.size(); ++j) {
    const std::uint64_t key = scanKey(reference.scans[j]);
    const auto found = by_ranges.find(key);
    if (found == by_ranges.end()) continue;
    if (found->second.size() != 1 || reference_count[key] != 1) {
      ++result.ambiguous;
      continue;
    }
    source[found->second.front()] = j;
    ++result.matched;
  }
  if (result.matched < 2)
    throw std::invalid_argument("reference truth: " + std::to_string(result.matched) + " scan(s) of " + reference.source +
                                " have the ranges of a scan of " + sequence->source + " (2 at least: the same drive)");
  // The nearest matched scan before and after each scan, by index.
  const std::size_t n = sequence->scans.size();
  std::vector<std::size_t> before(n, kNone), after(n, kNone);
  for (std::size_t i = 0, last = kNone; i < n; ++i) {
    if (source[i] != kNone) last = i;
    before[i] = last;
  }
  for (std::size_t i = n, next = kNone; i-- > 0;) {
    if (source[i] != kNone) next = i;
    after[i] = next;
  }
  std::vector<Pose2> truth(n);
  result.gap_miss_m.assign(n, 0.0);
  result.gap_miss_rad.assign(n, 0.0);
  const std::vector<Pose2> odometry = odometryWithoutStalls(*sequence, &result.stalled_odometry);
  auto carriedFrom = [&](std::size_t m, std::size_t i) {
    return compose(reference.scans[source[m]].truth, between(odometry[m], odometry[i]));
  };
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t b = before[i], a = after[i];
    if (b == i) {
      truth[i] = reference.scans[source[i]].truth;
      continue;
    }
    ++result.carried;
    if (b == kNone || a == kNone) {  // before the first matched scan or after the last
      const std::size_t m = b == kNone ? a : b;
      truth[i] = carriedFrom(m, i);
      result.gap_miss_m[i] = result.gap_miss_rad[i] = std::numeric_limits<double>::quiet_NaN();
      result.max_carry_scans = std::max(result.max_carry_scans, m > i ? m - i : i - m);
      continue;
    }
    // Between two matched scans: carried from each, blended by how near each is, so that the
    // odometry's error over the gap is spread along it rather than left as a jump at one end.
    const Pose2 from_before = carriedFrom(b, i), from_after = carriedFrom(a, i);
    const Pose2 miss = between(reference.scans[source[a]].truth, carriedFrom(b, a));
    result.gap_miss_m[i] = std::hypot(miss.x, miss.y);
    result.gap_miss_rad[i] = std::abs(normalizeAngle(miss.theta));
    const double w = double(i - b) / double(a - b);
    truth[i] = {(1.0 - w) * from_before.x + w * from_after.x, (1.0 - w) * from_before.y + w * from_after.y,
                normalizeAngle(from_before.theta + w * normalizeAngle(from_after.theta - from_before.theta))};
    result.max_carry_scans = std::max(result.max_carry_scans, std::min(i - b, a - i));
  }
  for (std::size_t i = 0; i < n; ++i) sequence->scans[i].truth = truth[i];
  result.matched_scans.resize(n);
  for (std::size_t i = 0; i < n; ++i) result.matched_scans[i] = source[i] != kNone;
  return result;
}

}  // namespace llc
