#include "laser_loop_closure/core/classifier/evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "laser_loop_closure/core/common/random.hpp"

namespace llc {
namespace {

std::pair<std::size_t, std::size_t> classCounts(const std::vector<int>& labels) {
  std::size_t positives = 0;
  for (int y : labels) positives += (y == 1);
  return {positives, labels.size() - positives};
}

/// Fold number of every row: positives and negatives each shuffled and dealt round-robin.
std::vector<int> stratifiedFolds(const std::vector<int>& labels, int folds, Random& random) {
  std::vector<int> fold(labels.size());
  for (int cls : {1, 0}) {
    std::vector<std::size_t> rows;
    for (std::size_t i = 0; i < labels.size(); ++i)
      if (labels[i] == cls) rows.push_back(i);
    random.shuffle(rows);
    for (std::size_t k = 0; k < rows.size(); ++k) fold[rows[k]] = int(k % std::size_t(folds));
  }
  return fold;
}

void splitFold(const std::vector<int>& fold, int f, std::vector<std::size_t>* train,
               std::vector<std::size_t>* test) {
  train->clear();
  test->clear();
  for (std::size_t i = 0; i < fold.size(); ++i) (fold[i] == f ? test : train)->push_back(i);
}

double mean(const std::vector<double>& v) {
  return v.empty() ? 0.0 : std::accumulate(v.begin(), v.end(), 0.0) / double(v.size());
}
double stddev(const std::vector<double>& v) {
  if (v.size() < 2) return 0.0;
  const double m = mean(v);
  double s = 0.0;
  for (double x : v) s += (x - m) * (x - m);
  return std::sqrt(s / double(v.size() - 1));
}

}  // namespace

std::vector<RocPoint> rocCurve(const std::vector<double>& scores, const std::vector<int>& labels) {
  const auto [positives, negatives] = classCounts(labels);
  std::vector<std::size_t> order(scores.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return scores[a] > scores[b]; });
  std::vector<RocPoint> curve;
  curve.push_back({std::numeric_limits<double>::infinity(), 0.0, 0.0});
  std::size_t tp = 0, fp = 0;
  for (std::size_t s = 0; s < order.size(); ++s) {
    const std::size_t i = order[s];
    (labels[i] == 1 ? tp : fp) += 1;
    if (s + 1 < order.size() && scores[order[s + 1]] == scores[i]) continue;  // ties together
    curve.push_back({scores[i], negatives ? double(fp) / double(negatives) : 0.0,
                     positives ? double(tp) / double(positives) : 0.0});
  }
  return curve;
}

double areaUnderCurve(const std::vector<double>& scores, const std::vector<int>& labels) {
  const std::vector<RocPoint> curve = rocCurve(scores, labels);
  const auto [positives, negatives] = classCounts(labels);
  if (positives == 0 || negatives == 0) return 0.5;
  double area = 0.0;  // trapezoids: a tie block is a diagonal, i.e. counts one half
  for (std::size_t i = 1; i < curve.size(); ++i)
    area += (curve[i].false_alarm - curve[i - 1].false_alarm) *
            0.5 * (curve[i].detection + curve[i - 1].detection);
  return area;
}

double detectionAtFalseAlarm(const std::vector<double>& scores, const std::vector<int>& labels,
                             double max_false_alarm, double* k) {
  double best = 0.0, best_k = std::numeric_limits<double>::infinity();
  for (const RocPoint& p : rocCurve(scores, labels))
    if (p.false_alarm <= max_false_alarm + 1e-12 && p.detection >= best) {
      best = p.detection;
      best_k = p.threshold;
    }
  if (k) *k = std::isfinite(best_k) ? best_k : 1.0;
  return best;
}

ErrorRates errorRates(const std::vector<double>& scores, const std::vector<int>& labels, double k) {
  const auto [positives, negatives] = classCounts(labels);
  std::size_t false_alarms = 0, misses = 0;
  for (std::size_t i = 0; i < scores.size(); ++i) {
    const bool match = scores[i] >= k;
    if (labels[i] == 1 && !match) ++misses;
    if (labels[i] == 0 && match) ++false_alarms;
  }
  ErrorRates rates;
  rates.false_alarm = negatives ? double(false_alarms) / double(negatives) : 0.0;
  rates.missed_detection = positives ? double(misses) / double(positives) : 0.0;
  return rates;
}

std::string CrossValidationOptions::validate() const {
  if (folds < 2) return "folds must be at least 2";
  if (repeats < 1) return "repeats must be at least 1";
  return adaboost.validate();
}

std::vector<CrossValidationRun> crossValidate(const TrainingSet& data,
                                              const CrossValidationOptions& options,
                                              const TrainingSet* alternate,
                                              const std::vector<TrainingSet>* companions) {
  const std::string invalid = options.validate();
  if (!invalid.empty()) throw std::invalid_argument("cross validation: " + invalid);
  const auto [positives, negatives] = classCounts(data.labels);
  if (positives < std::size_t(options.folds) || negatives < std::size_t(options.folds))
    throw std::invalid_argument("cross validation: each class needs at least as many pairs as folds (" +
                                std::to_string(positives) + " positive, " + std::to_string(negatives) +
                                " negative, " + std::to_string(options.folds) + " folds)");
  if (alternate && alternate->size() != data.size())
    throw std::invalid_argument("cross validation: the alternate rows must match the data rows");
  if (companions)
    for (const TrainingSet& rows : *companions)
      if (rows.size() != data.size() || rows.dimension != data.dimension)
        throw std::invalid_argument("cross validation: companion rows must match the data rows one for one");
  Random random(options.seed);
  const AdaBoostTrainer trainer(options.adaboost);
  std::vector<CrossValidationRun> runs(std::size_t(options.repeats));
  std::vector<std::size_t> train, test;
  for (CrossValidationRun& run : runs) {
    run.scores.assign(data.size(), 0.0);
    if (alternate) run.alternate_scores.assign(data.size(), 0.0);
    const std::vector<int> fold = stratifiedFolds(data.labels, options.folds, random);
    for (int f = 0; f < options.folds; ++f) {
      splitFold(fold, f, &train, &test);
      TrainingSet fold_training = data.subset(train);
      if (companions)
        for (const TrainingSet& rows : *companions) fold_training.append(rows.subset(train));
      const StrongClassifier classifier = trainer.train(fold_training).classifier;
      for (std::size_t i : test) {
        run.scores[i] = classifier.score(data.row(i));
        if (alternate) run.alternate_scores[i] = classifier.score(alternate->row(i));
      }
    }
  }
  return runs;
}

std::vector<ErrorRates> errorByRounds(const TrainingSet& data, int max_rounds, int folds,
                                      int repeats, std::uint64_t seed) {
  AdaBoostOptions boost;
  boost.rounds = max_rounds;
  const AdaBoostTrainer trainer(boost);
  Random random(seed);
  // Per T: scores of every row, pooled over folds, then rates averaged over repeats.
  std::vector<ErrorRates> sum(static_cast<std::size_t>(max_rounds));
  std::vector<std::size_t> train, test;
  for (int r = 0; r < repeats; ++r) {
    const std::vector<int> fold = stratifiedFolds(data.labels, folds, random);
    std::vector<std::vector<double>> scores(std::size_t(max_rounds), std::vector<double>(data.size(), 0.0));
    for (int f = 0; f < folds; ++f) {
      splitFold(fold, f, &train, &test);
      const StrongClassifier full = trainer.train(data.subset(train)).classifier;
      const std::vector<Stump>& stumps = full.stumps();
      for (std::size_t i : test) {
        double votes = 0.0, alphas = 0.0;
        for (std::size_t t = 0; t < std::size_t(max_rounds); ++t) {
          if (t < stumps.size()) {  // training may stop early: later T repeat the last classifier
            alphas += stumps[t].alpha;
            if (stumps[t].vote(data.row(i))) votes += stumps[t].alpha;
          }
          scores[t][i] = alphas > 0.0 ? votes / alphas : 0.0;
        }
      }
    }
    for (std::size_t t = 0; t < std::size_t(max_rounds); ++t) {
      const ErrorRates e = errorRates(scores[t], data.labels, 0.5);
      sum[t].false_alarm += e.false_alarm / repeats;
      sum[t].missed_detection += e.missed_detection / repeats;
    }
  }
  return sum;
}

std::vector<ErrorRates> errorWithoutEachFeature(const TrainingSet& data,
                                                const CrossValidationOptions& options) {
  std::vector<ErrorRates> result;
  for (std::size_t removed = 0; removed < data.dimension; ++removed) {
    CrossValidationOptions without = options;
    without.adaboost.allowed_features.clear();
    for (std::size_t f = 0; f < data.dimension; ++f)
      if (f != removed) without.adaboost.allowed_features.push_back(int(f));
    const CrossValidationSummary s = summarize(crossValidate(data, without), data.labels, 2);
    result.push_back(s.at_half);
  }
  return result;
}

CrossValidationSummary summarize(const std::vector<CrossValidationRun>& runs,
                                 const std::vector<int>& labels, std::size_t grid_points) {
  CrossValidationSummary s;
  std::vector<double> det1, det0, aucs;
  std::vector<double> all_scores;
  std::vector<int> all_labels;
  s.roc_false_alarm.resize(grid_points);
  s.roc_detection.assign(grid_points, 0.0);
  for (std::size_t g = 0; g < grid_points; ++g)
    s.roc_false_alarm[g] = grid_points > 1 ? double(g) / double(grid_points - 1) : 0.0;
  for (const CrossValidationRun& run : runs) {
    det1.push_back(detectionAtFalseAlarm(run.scores, labels, 0.01));
    det0.push_back(detectionAtFalseAlarm(run.scores, labels, 0.0));
    aucs.push_back(areaUnderCurve(run.scores, labels));
    const ErrorRates e = errorRates(run.scores, labels, 0.5);
    s.at_half.false_alarm += e.false_alarm / double(runs.size());
    s.at_half.missed_detection += e.missed_detection / double(runs.size());
    // Vertical averaging: best detection at each false-alarm level of the grid.
    const std::vector<RocPoint> curve = rocCurve(run.scores, labels);
    std::size_t c = 0;
    double best = 0.0;
    for (std::size_t g = 0; g < grid_points; ++g) {
      while (c < curve.size() && curve[c].false_alarm <= s.roc_false_alarm[g] + 1e-12)
        best = std::max(best, curve[c++].detection);
      s.roc_detection[g] += best / double(runs.size());
    }
    all_scores.insert(all_scores.end(), run.scores.begin(), run.scores.end());
    all_labels.insert(all_labels.end(), labels.begin(), labels.end());
  }
  s.detection_at_1pct = mean(det1);
  s.detection_at_1pct_std = stddev(det1);
  s.detection_at_0pct = mean(det0);
  s.auc = mean(aucs);
  s.auc_std = stddev(aucs);
  detectionAtFalseAlarm(all_scores, all_labels, 0.01, &s.k_at_1pct);
  return s;
}

}  // namespace llc
