#include "laser_loop_closure/core/classifier/classifier_training.hpp"

#include <algorithm>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "laser_loop_closure/core/classifier/evaluation.hpp"

namespace llc {

std::string ClassifierTrainingOptions::validate() const {
  if (rounds < 1) return "rounds must be at least 1";
  if (folds < 2) return "folds must be at least 2";
  if (repeats < 1) return "repeats must be at least 1";
  if (!(target_false_alarm >= 0.0 && target_false_alarm < 1.0)) return "target_false_alarm must lie in [0, 1)";
  return "";
}

ClassifierTrainingResult trainClassifierModel(const TrainingSet& set, const FeatureOptions& features,
                                              const ClassifierTrainingOptions& options,
                                              const std::vector<TrainingSet>* companions) {
  const std::string invalid = options.validate();
  if (!invalid.empty()) throw std::invalid_argument("classifier training: " + invalid);
  if (set.dimension != pairFeatureCount(features.feature_set))
    throw std::invalid_argument("classifier training: pair rows have " + std::to_string(set.dimension) +
                                " values, the feature set makes " +
                                std::to_string(pairFeatureCount(features.feature_set)));
  ClassifierTrainingResult result;
  result.pairs = set.size();
  for (int label : set.labels) result.positives += label == 1;

  // The stumps learn from the rows and their companions; without companions, from the rows as
  // given (no copy).
  TrainingSet with_companions;
  const bool augmented = companions && !companions->empty();
  if (augmented) {
    with_companions = set;
    for (const TrainingSet& rows : *companions) {
      if (rows.size() != set.size()) throw std::invalid_argument("classifier training: companion rows must match the rows one for one");
      with_companions.append(rows);
    }
  }
  const TrainingSet& all = augmented ? with_companions : set;
  AdaBoostOptions boost;
  boost.rounds = options.rounds;
  if (!options.excluded_features.empty()) {
    const std::vector<std::string>& names = pairFeatureNames(features.feature_set);
    for (const std::string& name : options.excluded_features)
      if (std::find(names.begin(), names.end(), name) == names.end())
        throw std::invalid_argument("classifier training: no pair feature '" + name + "' in the " +
                                    toString(features.feature_set) + " set");
    for (std::size_t f = 0; f < names.size(); ++f)
      if (std::find(options.excluded_features.begin(), options.excluded_features.end(), names[f]) ==
          options.excluded_features.end())
        boost.allowed_features.push_back(int(f));
  }
  const AdaBoostResult trained = AdaBoostTrainer(boost).train(all);
  if (trained.rounds.empty())
    throw std::invalid_argument("classifier training failed: " + trained.stopped_early);
  result.note = trained.stopped_early;
  result.model.features = features;
  result.model.classifier = trained.classifier;

  // K from scores of classifiers that never saw the pair (crossValidate checks the classes).
  CrossValidationOptions cv;
  cv.folds = options.folds;
  cv.repeats = options.repeats;
  cv.seed = options.seed;
  cv.adaboost = boost;
  std::vector<double> scores;
  std::vector<int> labels;
  for (const CrossValidationRun& run : crossValidate(set, cv, nullptr, companions)) {
    scores.insert(scores.end(), run.scores.begin(), run.scores.end());
    labels.insert(labels.end(), set.labels.begin(), set.labels.end());
  }
  double k = 0.5;
  result.detection = detectionAtFalseAlarm(scores, labels, options.target_false_alarm, &k);
  result.auc = areaUnderCurve(scores, labels);
  result.model.classifier.setThresholdK(k);

  std::ostringstream why;
  why << "cross-validated (" << options.folds << " folds x " << options.repeats << ") for false alarm <= "
      << options.target_false_alarm << ": detection " << std::setprecision(4) << result.detection << ", AUC "
      << result.auc;
  result.model.provenance["threshold_k"] = why.str();
  result.model.provenance["pairs"] = std::to_string(set.size());
  if (!options.excluded_features.empty()) {
    std::string list;
    for (const std::string& name : options.excluded_features) list += (list.empty() ? "" : ",") + name;
    result.model.provenance["excluded_features"] = list;
  }
  if (augmented)
    result.model.provenance["augmented_rows"] = std::to_string(all.size() - set.size());
  return result;
}

ModelRates rateModel(const StrongClassifier& classifier, const TrainingSet& set, double target_false_alarm) {
  std::vector<double> scores;
  scores.reserve(set.size());
  for (std::size_t i = 0; i < set.size(); ++i) scores.push_back(classifier.score(set.row(i)));
  ModelRates rates;
  rates.detection = detectionAtFalseAlarm(scores, set.labels, target_false_alarm);
  rates.auc = areaUnderCurve(scores, set.labels);
  return rates;
}

TrainingSet pairTrainingSet(const std::vector<std::vector<double>>& scan_features,
                            const std::vector<LabeledPair>& pairs, FeatureSet feature_set) {
  TrainingSet set;
  set.dimension = pairFeatureCount(feature_set);
  std::vector<double> row(set.dimension);
  for (const LabeledPair& p : pairs) {
    if (p.a >= scan_features.size() || p.b >= scan_features.size())
      throw std::out_of_range("pair (" + std::to_string(p.a) + ", " + std::to_string(p.b) + ") names a scan beyond " +
                              std::to_string(scan_features.size()));
    pairFeatures(feature_set, scan_features[p.a].data(), scan_features[p.b].data(), row.data());
    set.add(row.data(), p.label);
  }
  return set;
}

TrainingSet keyframeTrainingSet(const std::vector<std::vector<double>>& keyframe_features,
                                const std::vector<Pose2>& poses, FeatureSet feature_set,
                                const PairLabelingOptions& labeling, std::vector<LabeledPair>* pairs) {
  if (keyframe_features.size() != poses.size())
    throw std::invalid_argument("keyframe training set: " + std::to_string(keyframe_features.size()) +
                                " feature vectors but " + std::to_string(poses.size()) + " poses");
  const PairLabelingResult labelled = labelPairs(poses, labeling);
  if (pairs) *pairs = labelled.pairs;
  return pairTrainingSet(keyframe_features, labelled.pairs, feature_set);
}

TrainingSet selfLabelledTrainingSet(const std::vector<std::vector<double>>& keyframe_features,
                                    const std::vector<Pose2>& optimised_poses, FeatureSet feature_set,
                                    bool full_circle, std::size_t min_keyframe_gap, std::vector<LabeledPair>* pairs) {
  PairLabelingOptions labeling;
  labeling.full_circle = full_circle;
  labeling.min_index_gap = min_keyframe_gap;
  return keyframeTrainingSet(keyframe_features, optimised_poses, feature_set, labeling, pairs);
}

}  // namespace llc
