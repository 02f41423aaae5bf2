#include "laser_loop_closure/core/classifier/log_out_evaluation.hpp"

#include <algorithm>
#include <stdexcept>

#include "laser_loop_closure/core/classifier/evaluation.hpp"
#include "laser_loop_closure/core/classifier/threshold_calibration.hpp"

namespace llc {

LeaveOneLogOutResult leaveOneLogOut(const std::vector<TrainingSet>& logs, const std::vector<std::string>& names,
                                    const ClassifierFitter& fit, const std::vector<TrainingSet>* extra_negatives,
                                    const std::vector<TrainingSet>* calibration_pairs, double calibration_false_alarm) {
  if (logs.size() < 2) throw std::invalid_argument("leave-one-log-out needs at least two logs");
  if (extra_negatives && extra_negatives->size() != logs.size())
    throw std::invalid_argument("leave-one-log-out: one set of extra negatives per log");
  if (calibration_pairs && calibration_pairs->size() != logs.size())
    throw std::invalid_argument("leave-one-log-out: one set of calibration pairs per log");
  for (const TrainingSet& log : logs)
    if (log.dimension != logs.front().dimension) throw std::invalid_argument("leave-one-log-out: logs of different dimensions");
  LeaveOneLogOutResult result;
  for (std::size_t held_out = 0; held_out < logs.size(); ++held_out) {
    TrainingSet training;
    training.dimension = logs.front().dimension;
    for (std::size_t other = 0; other < logs.size(); ++other)
      if (other != held_out) training.append(logs[other]);
    const StrongClassifier model = fit(training);

    const TrainingSet& test = logs[held_out];
    HeldOutLog out;
    out.name = held_out < names.size() && !names[held_out].empty() ? names[held_out] : "log " + std::to_string(held_out + 1);
    out.pairs = test.size();
    out.training_pairs = training.size();
    out.k = model.thresholdK();
    for (std::size_t i = 0; i < test.size(); ++i) out.scores.push_back(model.score(test.row(i)));
    for (int y : test.labels) out.positives += y == 1;
    // Negatives for the realised false-alarm rate: the log's own, then any extra ones.
    std::vector<double> negative_scores;
    for (std::size_t i = 0; i < test.size(); ++i)
      if (test.labels[i] == 0) negative_scores.push_back(out.scores[i]);
    if (extra_negatives) {
      const TrainingSet& extra = (*extra_negatives)[held_out];
      if (extra.size() && extra.dimension != test.dimension) throw std::invalid_argument("leave-one-log-out: extra negatives of another dimension");
      for (std::size_t i = 0; i < extra.size(); ++i) {
        if (extra.labels[i] != 0) throw std::invalid_argument("leave-one-log-out: an extra negative labelled 1");
        out.extra_scores.push_back(model.score(extra.row(i)));
        negative_scores.push_back(out.extra_scores.back());
      }
    }
    out.false_alarm_negatives = negative_scores.size();
    auto falseAlarmAt = [&](double k) {
      std::size_t reached = 0;
      for (double score : negative_scores) reached += score >= k;
      return negative_scores.empty() ? 0.0 : double(reached) / double(negative_scores.size());
    };
    out.detection_at_k = 1.0 - errorRates(out.scores, test.labels, out.k).missed_detection;
    out.realised_false_alarm = falseAlarmAt(out.k);
    if (calibration_pairs && (*calibration_pairs)[held_out].size()) {
      const TrainingSet& calibration = (*calibration_pairs)[held_out];
      if (calibration.dimension != test.dimension) throw std::invalid_argument("leave-one-log-out: calibration pairs of another dimension");
      std::vector<double> calibration_scores;
      for (std::size_t i = 0; i < calibration.size(); ++i) calibration_scores.push_back(model.score(calibration.row(i)));
      out.calibration_pairs = calibration.size();
      out.calibrated_k = thresholdForFalseAlarm(calibration_scores, calibration_false_alarm);
      out.detection_at_calibrated_k = 1.0 - errorRates(out.scores, test.labels, out.calibrated_k).missed_detection;
      out.realised_false_alarm_calibrated = falseAlarmAt(out.calibrated_k);
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
