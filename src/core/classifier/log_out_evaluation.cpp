#include "laser_loop_closure/core/classifier/log_out_evaluation.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>

#include "laser_loop_closure/core/classifier/evaluation.hpp"
#include "laser_loop_closure/core/classifier/threshold_calibration.hpp"

namespace llc {
namespace {

/// The rows of every log but those in `left_out`, in log order; per augmentation kind, the
/// same logs' augmented rows in the same order (row for row: companions of those rows).
TrainingSet trainingWithout(const std::vector<TrainingSet>& logs, const LogOutAugmentation* augmentation,
                            std::size_t left_out, std::size_t also_left_out, std::vector<TrainingSet>* companions) {
  TrainingSet training;
  training.dimension = logs.front().dimension;
  for (std::size_t other = 0; other < logs.size(); ++other)
    if (other != left_out && other != also_left_out) training.append(logs[other]);
  companions->clear();
  if (augmentation)
    for (const std::vector<TrainingSet>& kind : *augmentation) {
      TrainingSet rows;
      rows.dimension = training.dimension;
      for (std::size_t other = 0; other < logs.size(); ++other)
        if (other != left_out && other != also_left_out) rows.append(kind[other]);
      companions->push_back(std::move(rows));
    }
  return training;
}

std::vector<double> scoresOf(const StrongClassifier& model, const TrainingSet& set) {
  std::vector<double> scores;
  for (std::size_t i = 0; i < set.size(); ++i) scores.push_back(model.score(set.row(i)));
  return scores;
}

/// Share of `negative_scores` at or above k (0 when there are none).
double falseAlarmAt(const std::vector<double>& negative_scores, double k) {
  std::size_t reached = 0;
  for (double score : negative_scores) reached += score >= k;
  return negative_scores.empty() ? 0.0 : double(reached) / double(negative_scores.size());
}

ThresholdCalibrationOptions calibrationOptions(const LogOutCalibration& calibration, double target) {
  ThresholdCalibrationOptions options;
  options.target_false_alarm = target;
  options.raise_only = calibration.raise_only;
  return options;
}

/// Scores of a log's negatives that a model gives: its labelled negatives, then any extra ones.
std::vector<double> negativeScores(const StrongClassifier& model, const TrainingSet& log, const TrainingSet* extra,
                                   std::vector<double>* log_scores, std::vector<double>* extra_scores) {
  *log_scores = scoresOf(model, log);
  std::vector<double> negatives;
  for (std::size_t i = 0; i < log.size(); ++i)
    if (log.labels[i] == 0) negatives.push_back((*log_scores)[i]);
  if (extra) {
    if (extra->size() && extra->dimension != log.dimension) throw std::invalid_argument("leave-one-log-out: extra negatives of another dimension");
    for (std::size_t i = 0; i < extra->size(); ++i)
      if (extra->labels[i] != 0) throw std::invalid_argument("leave-one-log-out: an extra negative labelled 1");
    *extra_scores = scoresOf(model, *extra);
    negatives.insert(negatives.end(), extra_scores->begin(), extra_scores->end());
  }
  return negatives;
}

/// The calibration target for held-out log `held_out`, chosen on the other logs only, each
/// scored by a model fitted without it and without `held_out`.
double nestedCalibrationTarget(const std::vector<TrainingSet>& logs, const LogOutAugmentation* augmentation,
                               std::size_t held_out, const ClassifierFitter& fit,
                               const std::vector<TrainingSet>* extra_negatives, const LogOutCalibration& calibration) {
  const std::vector<double>& targets = calibration.candidate_targets;
  std::vector<std::size_t> outside(targets.size(), 0);  // per target: other logs outside the band
  for (std::size_t other = 0; other < logs.size(); ++other) {
    if (other == held_out || (*calibration.pairs)[other].size() == 0) continue;
    std::vector<TrainingSet> companions;
    const TrainingSet training = trainingWithout(logs, augmentation, held_out, other, &companions);
    const StrongClassifier model = fit(training, companions);
    std::vector<double> log_scores, extra_scores;
    const std::vector<double> negatives = negativeScores(
        model, logs[other], extra_negatives ? &(*extra_negatives)[other] : nullptr, &log_scores, &extra_scores);
    const std::vector<double> calibration_scores = scoresOf(model, (*calibration.pairs)[other]);
    for (std::size_t t = 0; t < targets.size(); ++t) {
      const double k = calibratedThreshold(calibration_scores, model.thresholdK(), calibrationOptions(calibration, targets[t]));
      const double realised = falseAlarmAt(negatives, k);
      outside[t] += realised < calibration.band_low || realised > calibration.band_high;
    }
  }
  // The smallest target among those leaving the fewest logs outside (ties: the stricter K).
  std::size_t best = 0;
  for (std::size_t t = 1; t < targets.size(); ++t)
    if (outside[t] < outside[best] || (outside[t] == outside[best] && targets[t] < targets[best])) best = t;
  return targets[best];
}

}  // namespace

LeaveOneLogOutResult leaveOneLogOut(const std::vector<TrainingSet>& logs, const std::vector<std::string>& names,
                                    const ClassifierFitter& fit, const std::vector<TrainingSet>* extra_negatives,
                                    const LogOutCalibration* calibration, const LogOutAugmentation* augmentation) {
  if (logs.size() < 2) throw std::invalid_argument("leave-one-log-out needs at least two logs");
  if (augmentation)
    for (const std::vector<TrainingSet>& kind : *augmentation)
      if (kind.size() != logs.size()) throw std::invalid_argument("leave-one-log-out: one set of augmented rows per log");
  if (extra_negatives && extra_negatives->size() != logs.size())
    throw std::invalid_argument("leave-one-log-out: one set of extra negatives per log");
  if (calibration && !calibration->pairs) calibration = nullptr;
  if (calibration && calibration->pairs->size() != logs.size())
    throw std::invalid_argument("leave-one-log-out: one set of calibration pairs per log");
  if (calibration && !calibration->candidate_targets.empty() && logs.size() < 3)
    throw std::invalid_argument("leave-one-log-out: choosing the calibration target without the held-out log needs at least three logs");
  for (const TrainingSet& log : logs)
    if (log.dimension != logs.front().dimension) throw std::invalid_argument("leave-one-log-out: logs of different dimensions");
  if (augmentation)
    for (const std::vector<TrainingSet>& kind : *augmentation)
      for (std::size_t log = 0; log < logs.size(); ++log)
        if (kind[log].size() != logs[log].size() || (kind[log].size() && kind[log].dimension != logs[log].dimension))
          throw std::invalid_argument("leave-one-log-out: augmented rows must match their log's rows one for one");
  if (calibration)
    for (const TrainingSet& pairs : *calibration->pairs)
      if (pairs.size() && pairs.dimension != logs.front().dimension)
        throw std::invalid_argument("leave-one-log-out: calibration pairs of another dimension");
  LeaveOneLogOutResult result;
  for (std::size_t held_out = 0; held_out < logs.size(); ++held_out) {
    std::vector<TrainingSet> companions;
    const TrainingSet training = trainingWithout(logs, augmentation, held_out, held_out, &companions);
    const StrongClassifier model = fit(training, companions);

    const TrainingSet& test = logs[held_out];
    HeldOutLog out;
    out.name = held_out < names.size() && !names[held_out].empty() ? names[held_out] : "log " + std::to_string(held_out + 1);
    out.pairs = test.size();
    out.training_pairs = training.size();
    out.k = model.thresholdK();
    for (int y : test.labels) out.positives += y == 1;
    // Negatives for the realised false-alarm rate: the log's own, then any extra ones.
    const std::vector<double> negative_scores =
        negativeScores(model, test, extra_negatives ? &(*extra_negatives)[held_out] : nullptr, &out.scores, &out.extra_scores);
    out.false_alarm_negatives = negative_scores.size();
    out.detection_at_k = 1.0 - errorRates(out.scores, test.labels, out.k).missed_detection;
    out.realised_false_alarm = falseAlarmAt(negative_scores, out.k);
    if (calibration && (*calibration->pairs)[held_out].size()) {
      out.calibration_target = calibration->candidate_targets.empty()
                                   ? calibration->target_false_alarm
                                   : nestedCalibrationTarget(logs, augmentation, held_out, fit, extra_negatives, *calibration);
      const std::vector<double> calibration_scores = scoresOf(model, (*calibration->pairs)[held_out]);
      out.calibration_pairs = calibration_scores.size();
      out.calibrated_k = calibratedThreshold(calibration_scores, out.k, calibrationOptions(*calibration, out.calibration_target));
      out.detection_at_calibrated_k = 1.0 - errorRates(out.scores, test.labels, out.calibrated_k).missed_detection;
      out.realised_false_alarm_calibrated = falseAlarmAt(negative_scores, out.calibrated_k);
    }
    out.detection_at_1pct = detectionAtFalseAlarm(out.scores, test.labels, 0.01);
    out.detection_at_0pct = detectionAtFalseAlarm(out.scores, test.labels, 0.0);
    out.auc = areaUnderCurve(out.scores, test.labels);
    result.logs.push_back(std::move(out));
  }
  const double n = double(result.logs.size());
  for (const HeldOutLog& log : result.logs) {
    result.mean_detection_at_1pct += log.detection_at_1pct / n;
    result.mean_detection_at_0pct += log.detection_at_0pct / n;
    result.mean_auc += log.auc / n;
    result.mean_detection_at_k += log.detection_at_k / n;
    result.mean_realised_false_alarm += log.realised_false_alarm / n;
    result.worst_realised_false_alarm = std::max(result.worst_realised_false_alarm, log.realised_false_alarm);
    result.mean_detection_at_calibrated_k += log.detection_at_calibrated_k / n;
    result.mean_realised_false_alarm_calibrated += log.realised_false_alarm_calibrated / n;
    result.worst_realised_false_alarm_calibrated = std::max(result.worst_realised_false_alarm_calibrated, log.realised_false_alarm_calibrated);
  }
  result.best_realised_false_alarm_calibrated = result.logs.front().realised_false_alarm_calibrated;
  for (const HeldOutLog& log : result.logs)
    result.best_realised_false_alarm_calibrated = std::min(result.best_realised_false_alarm_calibrated, log.realised_false_alarm_calibrated);
  return result;
}

}  // namespace llc
