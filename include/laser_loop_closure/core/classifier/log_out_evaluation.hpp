// Leave-one-log-out evaluation: the honest measure of a classifier on a building it has never
// seen. For each log, everything that is fitted (stumps, their thresholds, K) is fitted on the
// pairs of the other logs only, and the held-out log's pairs are scored by that model. Unlike
// pooled cross validation, no pair of the tested log (often the same corridor a few scans
// apart) is ever in the training set.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "laser_loop_closure/core/classifier/adaboost.hpp"

namespace llc {

/// One held-out log's figures.
struct HeldOutLog {
  std::string name;
  std::size_t pairs = 0, positives = 0;
  std::size_t training_pairs = 0;     ///< rows of the other logs the model was trained on
  double k = 0.0;                     ///< the model's own threshold, fitted without this log
  double detection_at_k = 0.0;        ///< positives at or above k
  double realised_false_alarm = 0.0;  ///< negatives at or above k: what a user of the model gets
  std::size_t false_alarm_negatives = 0;  ///< negatives that rate counts (the log's own plus any extra)
  double detection_at_1pct = 0.0;     ///< best detection with <= 1% false alarm on this log (oracle K)
  double detection_at_0pct = 0.0;     ///< best detection with no false alarm on this log (oracle K)
  double auc = 0.0;
  // With calibration pairs (ThresholdCalibration): K fitted on the held-out log's own
  // surely-different pairs (by its odometry, no label), and what that K gives.
  std::size_t calibration_pairs = 0;
  double calibration_target = 0.0;  ///< the target it was fitted for (chosen without this log when nested)
  double calibrated_k = 0.0;
  double detection_at_calibrated_k = 0.0;
  double realised_false_alarm_calibrated = 0.0;  ///< over the same negatives as realised_false_alarm
  std::vector<double> scores;         ///< each pair's score, in the log's row order
  std::vector<double> extra_scores;   ///< each extra negative's score, in its row order
};

struct LeaveOneLogOutResult {
  std::vector<HeldOutLog> logs;
  /// Means over the logs (each log counts once, whatever its size).
  double mean_detection_at_1pct = 0.0, mean_detection_at_0pct = 0.0, mean_auc = 0.0;
  double mean_detection_at_k = 0.0, mean_realised_false_alarm = 0.0;
  double worst_realised_false_alarm = 0.0;  ///< the largest over the logs
  double mean_detection_at_calibrated_k = 0.0, mean_realised_false_alarm_calibrated = 0.0;
  double best_realised_false_alarm_calibrated = 0.0, worst_realised_false_alarm_calibrated = 0.0;  ///< smallest, largest
};

/// Fits a classifier (stumps and K) on a training set and, per augmentation kind, that set's
/// rows augmented (row for row; empty without augmentation: trainClassifierModel's
/// companions). It must see nothing but its arguments.
using ClassifierFitter = std::function<StrongClassifier(const TrainingSet& training, const std::vector<TrainingSet>& companions)>;

/// Per augmentation kind, per log: that log's rows with both scans of each pair augmented
/// (augmentedPairSet), row for row.
using LogOutAugmentation = std::vector<std::vector<TrainingSet>>;

/// K calibrated per held-out log (ThresholdCalibration), as a robot would in that building.
struct LogOutCalibration {
  /// One set per log (labels ignored): pairs of that log that its own odometry says are surely
  /// two places (sampleSurelyDifferentPairs). Never used for fitting.
  const std::vector<TrainingSet>* pairs = nullptr;
  double target_false_alarm = 0.015;  ///< share of those pairs allowed at or above K
  bool raise_only = true;             ///< never below the model's own K (ThresholdCalibrationOptions)
  /// Non-empty: the target is chosen for each held-out log H without it (nested): every other
  /// log O is scored by a model fitted on neither H nor O, and the smallest target here that
  /// keeps every O's realised false alarm within [band_low, band_high] is taken (if none does,
  /// the one that leaves the fewest outside). target_false_alarm is then not used.
  std::vector<double> candidate_targets;
  double band_low = 0.005, band_high = 0.02;
};

/// For each log: fit on the rows of every other log, score the log. Needs at least two logs of
/// one dimension (std::invalid_argument otherwise); names may be empty (then "log N").
/// extra_negatives (optional, one set per log, label 0): more negatives of that log, scored
/// only for its realised false-alarm rate (a balanced set of 35 negatives cannot tell 1% from
/// 2.9%); never used for fitting.
/// calibration (optional, with pairs): the held-out model's K is fitted again on the scores of
/// the log's calibration pairs (calibratedThreshold) and scored like the model's own K.
/// augmentation (optional): each log's pairs as another scanner would see them, given to the
/// fitter of every model that may see the log as companions of its rows; never scored, so a
/// held-out log is tested on its own scans alone.
LeaveOneLogOutResult leaveOneLogOut(const std::vector<TrainingSet>& logs, const std::vector<std::string>& names,
                                    const ClassifierFitter& fit, const std::vector<TrainingSet>* extra_negatives = nullptr,
                                    const LogOutCalibration* calibration = nullptr,
                                    const LogOutAugmentation* augmentation = nullptr);

}  // namespace llc
