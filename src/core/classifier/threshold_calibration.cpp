#include "laser_loop_closure/core/classifier/threshold_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>

namespace llc {

std::string ThresholdCalibrationOptions::validate() const {
  if (!(target_false_alarm > 0.0 && target_false_alarm < 1.0)) return "threshold_calibration: target_false_alarm must be in (0, 1)";
  if (!(min_distance >= 0.0) || !std::isfinite(min_distance)) return "threshold_calibration: min_distance must be finite and >= 0";
  if (!(drift_per_metre >= 0.0) || !std::isfinite(drift_per_metre)) return "threshold_calibration: drift_per_metre must be finite and >= 0";
  if (!(max_path > 0.0) || !std::isfinite(max_path)) return "threshold_calibration: max_path must be finite and > 0";
  if (min_pairs < 1) return "threshold_calibration: min_pairs must be at least 1";
  if (max_pairs < min_pairs) return "threshold_calibration: max_pairs must be at least min_pairs";
  if (pairs_per_keyframe < 1) return "threshold_calibration: pairs_per_keyframe must be at least 1";
  return "";
}

bool surelyDifferentPlaces(const Pose2& a, const Pose2& b, double path, const ThresholdCalibrationOptions& options) {
  if (!(path >= 0.0) || path > options.max_path) return false;
  const double distance = std::hypot(b.x - a.x, b.y - a.y);
  return distance > options.min_distance + options.drift_per_metre * path;  // false for NaN
}

std::vector<double> pathLengths(const std::vector<Pose2>& odometry) {
  std::vector<double> path(odometry.size(), 0.0);
  for (std::size_t i = 1; i < odometry.size(); ++i) {
    const double step = std::hypot(odometry[i].x - odometry[i - 1].x, odometry[i].y - odometry[i - 1].y);
    path[i] = path[i - 1] + (std::isfinite(step) ? step : 0.0);
  }
  return path;
}

std::vector<LabeledPair> sampleSurelyDifferentPairs(const std::vector<Pose2>& odometry,
                                                    const ThresholdCalibrationOptions& options,
                                                    std::size_t count, std::uint64_t seed) {
  const std::string invalid = options.validate();
  if (!invalid.empty()) throw std::invalid_argument(invalid);
  const std::vector<double> path = pathLengths(odometry);
  // Only pairs within max_path of driving qualify, so a window per first scan lists them all.
  std::vector<LabeledPair> pairs;
  for (std::size_t a = 0; a < odometry.size(); ++a)
    for (std::size_t b = a + 1; b < odometry.size() && path[b] - path[a] <= options.max_path; ++b)
      if (surelyDifferentPlaces(odometry[a], odometry[b], path[b] - path[a], options)) pairs.push_back({a, b, 0});
  Random random(seed);
  random.shuffle(pairs);
  if (pairs.size() > count) pairs.resize(count);
  return pairs;
}

double thresholdForFalseAlarm(std::vector<double> negative_scores, double target) {
  if (negative_scores.empty()) throw std::invalid_argument("thresholdForFalseAlarm: no scores");
  const std::size_t n = negative_scores.size();
  const std::size_t allowed = std::min(n - 1, std::size_t(std::floor(std::max(0.0, target) * double(n))));
  // The (allowed+1)-th largest score must stay below K: K just above it lets at most `allowed` through.
  std::nth_element(negative_scores.begin(), negative_scores.begin() + std::ptrdiff_t(allowed), negative_scores.end(),
                   std::greater<double>());
  const double blocked = negative_scores[allowed];
  return std::nextafter(blocked, std::numeric_limits<double>::infinity());
}

ThresholdCalibrator::ThresholdCalibrator(const ThresholdCalibrationOptions& options, std::uint64_t seed)
    : options_(options), random_(seed) {
  const std::string invalid = options.validate();
  if (!invalid.empty()) throw std::invalid_argument(invalid);
}

void ThresholdCalibrator::add(double score) {
  if (!std::isfinite(score)) return;
  ++seen_;
  if (kept_.size() < options_.max_pairs) {
    kept_.push_back(score);
    return;
  }
  const std::uint64_t slot = random_.index(seen_);  // reservoir: every score seen is kept with equal chance
  if (slot < kept_.size()) kept_[slot] = score;
}

namespace {

/// The fitted K, with the model's K as its floor when raise_only.
double applyRaiseOnly(double fitted, double model_k, const ThresholdCalibrationOptions& options) {
  return options.raise_only ? std::max(fitted, model_k) : fitted;
}

}  // namespace

double calibratedThreshold(const std::vector<double>& scores, double model_k, const ThresholdCalibrationOptions& options) {
  return applyRaiseOnly(thresholdForFalseAlarm(scores, options.target_false_alarm), model_k, options);
}

double ThresholdCalibrator::threshold(double model_k) {
  if (!calibrated()) return model_k;
  if (fitted_at_ == 0 || double(seen_ - fitted_at_) >= 0.01 * double(fitted_at_)) {
    fitted_ = thresholdForFalseAlarm(kept_, options_.target_false_alarm);
    fitted_at_ = seen_;
  }
  return applyRaiseOnly(fitted_, model_k, options_);
}

void ThresholdCalibrator::clear() {
  kept_.clear();
  seen_ = 0;
  fitted_at_ = 0;
}

}  // namespace llc
