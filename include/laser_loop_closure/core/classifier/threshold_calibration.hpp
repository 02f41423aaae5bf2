// A classifier threshold K that holds in a building the model never saw. The model's own K is
// fitted for 1% false alarm on the training buildings; in a building of look-alike corridors
// its negatives score higher and far more than 1% pass (5.8% on MIT's infinite corridor held
// out). So K is fitted again in the robot's own building, from pairs of keyframes that its own
// odometry says are surely two places: farther apart than min_distance plus all the drift the
// odometry can have gathered on the path between them. Such pairs need no label, no loop and
// no map; their scores are the building's own negatives.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "laser_loop_closure/core/classifier/pair_labeling.hpp"
#include "laser_loop_closure/core/common/random.hpp"
#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc {

struct ThresholdCalibrationOptions {
  bool enabled = true;                 ///< false: the model's K (or score_threshold) throughout
  /// Share of surely-different pairs allowed at or above K. They are near along the path (the
  /// same corridor further on), so they look more alike than a building's negatives as a whole:
  /// 1.5% of them gives about 1% of those (chosen by nested leave-one-log-out, docs/results.md).
  double target_false_alarm = 0.015;
  /// K may only rise above the model's own: the calibration guards against a building whose
  /// places look more alike than the training buildings' (MIT's infinite corridor), and never
  /// loosens a K that holds (lowered, it let 2.1% through on freiburg-101). false: up or down.
  bool raise_only = true;
  double min_distance = 10.0;          ///< m; apart by odometry beyond this plus the drift allowance
  double drift_per_metre = 0.3;        ///< m of odometry error allowed per metre driven between the two
  double max_path = 50.0;              ///< m; pairs farther apart along the path are not used (drift unbounded)
  std::size_t min_pairs = 1000;        ///< scored pairs before K is calibrated (the model's K until then)
  std::size_t max_pairs = 100000;      ///< scores kept (a uniform reservoir of all seen); bounds memory
  std::size_t pairs_per_keyframe = 20; ///< surely-different older keyframes scored per new keyframe
  /// "" or what is wrong (a rate outside (0, 1), a negative or non-finite distance, ...).
  [[nodiscard]] std::string validate() const;
};

/// Whether two poses of one odometry chain, `path` metres of driving apart, are surely two
/// places: path <= max_path and distance > min_distance + drift_per_metre * path.
bool surelyDifferentPlaces(const Pose2& a, const Pose2& b, double path, const ThresholdCalibrationOptions& options);

/// Length driven up to each pose of the chain (0 at the first; non-finite steps count 0).
std::vector<double> pathLengths(const std::vector<Pose2>& odometry);

/// Up to `count` distinct pairs (a < b, label 0) of the chain that are surely two places,
/// drawn with `seed`; all of them when there are fewer.
std::vector<LabeledPair> sampleSurelyDifferentPairs(const std::vector<Pose2>& odometry,
                                                    const ThresholdCalibrationOptions& options,
                                                    std::size_t count, std::uint64_t seed);

/// The smallest threshold that at most floor(target * n) of the n negative scores reach
/// (score >= K counts as reached). Throws std::invalid_argument for no scores.
double thresholdForFalseAlarm(std::vector<double> negative_scores, double target);

/// The K that calibration gives from surely-different pairs' scores: thresholdForFalseAlarm at
/// options.target_false_alarm, and with options.raise_only no lower than model_k.
double calibratedThreshold(const std::vector<double>& scores, double model_k, const ThresholdCalibrationOptions& options);

/// Gathers scores of surely-different pairs as a drive goes on and fits K from them.
class ThresholdCalibrator {
 public:
  /// Throws std::invalid_argument on invalid options.
  explicit ThresholdCalibrator(const ThresholdCalibrationOptions& options, std::uint64_t seed = 1);

  const ThresholdCalibrationOptions& options() const { return options_; }
  /// One surely-different pair's score (non-finite scores are ignored).
  void add(double score);
  std::size_t seen() const { return seen_; }
  bool calibrated() const { return options_.enabled && seen_ >= options_.min_pairs; }
  /// The calibrated K once calibrated() (calibratedThreshold, model_k the floor when
  /// raise_only), else model_k. Fitted again when the scores seen grew by 1% since the last
  /// fit (a fit sorts up to max_pairs scores).
  double threshold(double model_k);
  /// Forgets every score (a new building, or a model swapped in: the scores were another model's).
  void clear();

 private:
  ThresholdCalibrationOptions options_;
  Random random_;
  std::vector<double> kept_;
  std::size_t seen_ = 0;
  double fitted_ = 0.0;
  std::size_t fitted_at_ = 0;  ///< seen_ when fitted_ was computed (0: never)
};

}  // namespace llc
