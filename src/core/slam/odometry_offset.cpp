#include "laser_loop_closure/core/slam/odometry_offset.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <iomanip>
#include <iterator>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace llc {

std::string OdometryOffsetOptions::validate() const {
  if (max_offset < 0 || max_offset > 50) return "max_offset must be in [0, 50]";
  if (max_pairs == 0) return "max_pairs must be > 0";
  if (!(min_motion >= 0.0)) return "min_motion must be >= 0";
  return "";
}

namespace {

double mean(const std::vector<double>& values) {
  double sum = 0.0;
  for (const double v : values) sum += v;
  return values.empty() ? 0.0 : sum / double(values.size());
}

/// Paired t statistic of a - b over the pairs matched in both (0 with fewer than 2 such pairs or
/// no spread); `count` gets their number.
double pairedT(const std::vector<double>& a, const std::vector<double>& b, std::size_t* count) {
  std::vector<double> differences;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i)
    if (std::isfinite(a[i]) && std::isfinite(b[i])) differences.push_back(a[i] - b[i]);
  *count = differences.size();
  if (differences.size() < 2) return 0.0;
  const double m = mean(differences);
  double squares = 0.0;
  for (const double d : differences) squares += (d - m) * (d - m);
  const double standard_error = std::sqrt(squares / double(differences.size() - 1) / double(differences.size()));
  return standard_error > 0.0 ? m / standard_error : 0.0;
}

}  // namespace

void addOffsetPair(const OdometryStep& step, const Pose2& guess, OdometryOffsetScore* score) {
  ++score->pairs;
  score->correction_rad.push_back(std::numeric_limits<double>::quiet_NaN());
  if (!step.matched) return;
  ++score->matched;
  const Pose2 correction = between(guess, step.motion);
  // A running mean over the matched pairs (mean_correction_m is only ever read through here).
  score->mean_correction_m += (std::hypot(correction.x, correction.y) - score->mean_correction_m) / double(score->matched);
  score->correction_rad.back() = std::abs(correction.theta);
}

void pickBestOffset(OdometryOffsetResult* result_out, const std::string& unit) {
  OdometryOffsetResult& result = *result_out;
  result.ok = false;
  result.best_offset = 0;
  for (OdometryOffsetScore& s : result.scores) {
    std::vector<double> radians;  // of the matched pairs
    std::copy_if(s.correction_rad.begin(), s.correction_rad.end(), std::back_inserter(radians),
                 [](double r) { return std::isfinite(r); });
    s.mean_correction_rad = mean(radians);
  }
  const OdometryOffsetScore* best = nullptr;
  for (const OdometryOffsetScore& s : result.scores) {
    if (s.matched < s.pairs / 4) continue;  // a mean of a few lucky pairs says nothing
    if (!best || s.mean_correction_rad < best->mean_correction_rad ||
        (s.mean_correction_rad == best->mean_correction_rad && std::abs(s.offset) < std::abs(best->offset)))
      best = &s;
  }
  if (!best) {
    result.reason = "scan matching failed on most pairs at every offset";
    return;
  }
  result.ok = true;
  const OdometryOffsetScore* zero = nullptr;
  for (const OdometryOffsetScore& s : result.scores)
    if (s.offset == 0 && s.matched >= s.pairs / 4) zero = &s;
  std::ostringstream why;
  why << std::setprecision(3);
  if (best->offset == 0) {
    why << "offset 0 corrects least (" << best->mean_correction_rad << " rad)";
  } else if (!zero) {
    result.best_offset = best->offset;
    why << "offset " << best->offset << unit << ": scan matching failed on most pairs at offset 0";
  } else {
    result.best_offset = best->offset;
    std::size_t paired = 0;
    const double t = pairedT(zero->correction_rad, best->correction_rad, &paired);
    why << "offset " << best->offset << unit << " corrects " << best->mean_correction_rad << " rad against "
        << zero->mean_correction_rad << " at 0 (paired t " << t << " over " << paired << " pairs)";
  }
  result.reason = why.str();
}

OdometryOffsetResult estimateOdometryOffset(const ScanSequence& sequence, const ScanOdometry& odometry,
                                            const ScanAligner& aligner, const OdometryOffsetOptions& options) {
  const std::string error = options.validate();
  if (!error.empty()) throw std::invalid_argument("odometry offset options: " + error);
  OdometryOffsetResult result;
  if (!sequence.has_odometry) {
    result.reason = "the drive has no odometry";
    return result;
  }
  const long count = long(sequence.scans.size());
  const long reach = options.max_offset;
  // Pairs (i, i+1) far enough from both ends for every offset, where the odometry moved.
  std::vector<long> moving;
  for (long i = reach; i + 1 + reach < count; ++i) {
    const Pose2 motion = between(sequence.scans[std::size_t(i)].odometry, sequence.scans[std::size_t(i + 1)].odometry);
    if (std::hypot(motion.x, motion.y) >= options.min_motion || std::abs(motion.theta) >= options.min_motion)
      moving.push_back(i);
  }
  if (moving.size() < 10) {
    result.reason = "fewer than 10 consecutive scan pairs with odometry motion";
    return result;
  }
  std::vector<long> pairs;
  const std::size_t wanted = std::min(options.max_pairs, moving.size());
  for (std::size_t k = 0; k < wanted; ++k) pairs.push_back(moving[k * moving.size() / wanted]);

  std::map<long, std::shared_ptr<const PreparedScan>> prepared;
  auto scan = [&](long i) -> const PreparedScan& {
    auto& slot = prepared[i];
    if (!slot) slot = aligner.prepare(sequence.scans[std::size_t(i)].scan);
    return *slot;
  };
  for (int offset = -options.max_offset; offset <= options.max_offset; ++offset) {
    OdometryOffsetScore score;
    score.offset = offset;
    for (const long i : pairs) {
      const Pose2 guess = between(sequence.scans[std::size_t(i + offset)].odometry,
                                  sequence.scans[std::size_t(i + 1 + offset)].odometry);
      addOffsetPair(odometry.match(scan(i), scan(i + 1), {guess, true}), guess, &score);
    }
    result.scores.push_back(score);
  }
  pickBestOffset(&result, "");
  return result;
}

}  // namespace llc
