// The evaluation of the paper's section V: k-fold cross validation repeated with new
// shuffles, ROC, AUC, detection at a false-alarm rate, error against T, Table I tests.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "laser_loop_closure/core/classifier/adaboost.hpp"

namespace llc {

struct RocPoint {
  double threshold = 0.0;    ///< K: match iff score >= K
  double false_alarm = 0.0;  ///< share of negatives at or above K
  double detection = 0.0;    ///< share of positives at or above K
};

/// One point per distinct score (highest first), starting at (0, 0) and ending at (1, 1).
std::vector<RocPoint> rocCurve(const std::vector<double>& scores, const std::vector<int>& labels);
/// Area under the ROC curve (ties count one half), 0.5 when a class is missing.
double areaUnderCurve(const std::vector<double>& scores, const std::vector<int>& labels);
/// Highest detection rate with false-alarm rate <= max_false_alarm; the K reaching it in *k.
double detectionAtFalseAlarm(const std::vector<double>& scores, const std::vector<int>& labels,
                             double max_false_alarm, double* k = nullptr);

/// Rates of a fixed threshold K.
struct ErrorRates {
  double false_alarm = 0.0;        ///< negatives called matches / negatives
  double missed_detection = 0.0;   ///< positives called non-matches / positives
  double total() const { return false_alarm + missed_detection; }  ///< as in Table I
};
ErrorRates errorRates(const std::vector<double>& scores, const std::vector<int>& labels, double k);

struct CrossValidationOptions {
  int folds = 10;          ///< k of k-fold cross validation
  int repeats = 10;        ///< new shuffle each time (the paper: 100)
  std::uint64_t seed = 1;  ///< seeds the shuffles
  AdaBoostOptions adaboost;

  [[nodiscard]] std::string validate() const;
};

/// Scores of one repeat, pooled over its folds: scores[i] is row i's score from the classifier
/// of the fold that held row i out. `alternate` rows (e.g. one scan rotated) are scored by the
/// same classifiers.
struct CrossValidationRun {
  std::vector<double> scores;
  std::vector<double> alternate_scores;
};

/// Stratified folds: each fold holds about the same share of positives. Throws
/// std::invalid_argument on bad options or when a class has fewer rows than folds.
/// `companions` (optional): sets of rows that go with data's rows one for one (the same pairs
/// augmented): a companion trains with its row's training folds and is never scored, so a
/// fold's classifier never saw any form of the pairs it scores.
std::vector<CrossValidationRun> crossValidate(const TrainingSet& data,
                                              const CrossValidationOptions& options,
                                              const TrainingSet* alternate = nullptr,
                                              const std::vector<TrainingSet>* companions = nullptr);

/// Cross-validated error rates at K = 0.5 for every T = 1..max_rounds (one training of
/// max_rounds per fold: its first T stumps are what T rounds of training give).
std::vector<ErrorRates> errorByRounds(const TrainingSet& data, int max_rounds, int folds,
                                      int repeats, std::uint64_t seed);

/// Table I test 2: for each feature, cross-validated error at K = 0.5 without it.
std::vector<ErrorRates> errorWithoutEachFeature(const TrainingSet& data,
                                                const CrossValidationOptions& options);

/// Summary of repeated runs: mean detection at 1% and 0% false alarm, mean AUC, and the ROC
/// averaged vertically over the repeats on a grid of false-alarm rates.
struct CrossValidationSummary {
  double detection_at_1pct = 0.0, detection_at_1pct_std = 0.0;
  double detection_at_0pct = 0.0;
  double auc = 0.0, auc_std = 0.0;
  ErrorRates at_half;  ///< error rates at K = 0.5, pooled over repeats
  double k_at_1pct = 0.0;  ///< K reaching <= 1% false alarm on all repeats' scores together
  std::vector<double> roc_false_alarm, roc_detection;
};
CrossValidationSummary summarize(const std::vector<CrossValidationRun>& runs,
                                 const std::vector<int>& labels, std::size_t grid_points = 1001);

}  // namespace llc
