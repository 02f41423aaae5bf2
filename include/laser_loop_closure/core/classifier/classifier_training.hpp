// Training a classifier model from labelled pairs: AdaBoost on the pairs, K chosen from
// cross-validated scores for a target false-alarm rate (never from training scores), and the
// comparison with a running model that decides whether a retrained one may replace it.
// `llc train` and the loop_closure nodelet's ~train_classifier service both call it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "laser_loop_closure/core/classifier/classifier_model.hpp"
#include "laser_loop_closure/core/classifier/pair_labeling.hpp"
#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc {

struct ClassifierTrainingOptions {
  int rounds = 50;                   ///< AdaBoost rounds T (stumps)
  int folds = 10;                    ///< cross-validation folds for K and the reported rates
  int repeats = 1;                   ///< cross-validation repeats, each with a new shuffle
  std::uint64_t seed = 1;            ///< seeds the shuffles
  double target_false_alarm = 0.01;  ///< K is the lowest threshold keeping false alarms at or below this
  /// Pair features (pairFeatureNames) no stump may use (empty: every one): a feature study.
  std::vector<std::string> excluded_features;
  [[nodiscard]] std::string validate() const;
};

struct ClassifierTrainingResult {
  ClassifierModel model;      ///< trained on every pair, K set from the cross-validated scores
  double detection = 0.0;     ///< cross-validated detection at target_false_alarm
  double auc = 0.0;           ///< cross-validated area under the ROC
  std::size_t pairs = 0, positives = 0;
  std::string note;           ///< e.g. AdaBoost stopped early (a perfect stump)
};

/// Trains on `set` (rows are pairFeatures of `features.feature_set`). Throws
/// std::invalid_argument on bad options, a set of the wrong dimension, or a class with fewer
/// pairs than folds. `companions` (optional): set's rows augmented, one for one
/// (augmentedPairSet): the stumps learn from them too, and K's cross validation keeps each
/// with its row, so K is fitted on scores of pairs no fold's classifier saw in any form.
ClassifierTrainingResult trainClassifierModel(const TrainingSet& set, const FeatureOptions& features,
                                              const ClassifierTrainingOptions& options,
                                              const std::vector<TrainingSet>* companions = nullptr);

/// A fixed model on labelled pairs: detection at a false-alarm rate and AUC of its scores.
struct ModelRates {
  double detection = 0.0, auc = 0.0;
};
ModelRates rateModel(const StrongClassifier& classifier, const TrainingSet& set, double target_false_alarm);

/// Rows of every pair's features (pairFeatures of the two scans' features), labels kept.
TrainingSet pairTrainingSet(const std::vector<std::vector<double>>& scan_features,
                            const std::vector<LabeledPair>& pairs, FeatureSet feature_set);

/// Labelled pairs of keyframes from their (optimised) poses by labelPairs, as rows.
/// `pairs` (optional) receives the pairs. The features and poses must be as many.
TrainingSet keyframeTrainingSet(const std::vector<std::vector<double>>& keyframe_features,
                                const std::vector<Pose2>& poses, FeatureSet feature_set,
                                const PairLabelingOptions& labeling, std::vector<LabeledPair>* pairs = nullptr);

/// Self-training: the robot's own keyframe pairs labelled by its optimised map (keyframe
/// pairs the map puts within the labelling radius and heading are positives, pairs far apart
/// negatives), never two keyframes fewer than min_keyframe_gap apart in index as a positive
/// (those are odometry neighbours, not revisits). full_circle: every keyframe scan covers 360
/// degrees (then any heading may be a positive).
TrainingSet selfLabelledTrainingSet(const std::vector<std::vector<double>>& keyframe_features,
                                    const std::vector<Pose2>& optimised_poses, FeatureSet feature_set,
                                    bool full_circle, std::size_t min_keyframe_gap,
                                    std::vector<LabeledPair>* pairs = nullptr);

}  // namespace llc
