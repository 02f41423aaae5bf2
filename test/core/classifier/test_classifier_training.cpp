// Training a model from labelled pairs (llc train and ~train_classifier): K from
// cross-validated scores, the rates against a plain reference, session pairs from poses.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "laser_loop_closure/core/classifier/classifier_training.hpp"
#include "laser_loop_closure/core/classifier/evaluation.hpp"
#include "../test_util.hpp"

namespace {

const llc::FeatureSet kSet = llc::FeatureSet::kPaper;

llc::TrainingSet circleSet(std::vector<llc::LabeledPair>* pairs = nullptr) {
  return llc_test::circleTrainingSet(kSet, pairs);
}

llc::FeatureOptions paperSetOptions() {
  llc::FeatureOptions features;
  features.feature_set = kSet;
  return features;
}

/// 20 rounds, K from 5 folds: enough for the circle's separable pairs.
llc::ClassifierTrainingOptions quickTraining() {
  llc::ClassifierTrainingOptions options;
  options.rounds = 20;
  options.folds = 5;
  return options;
}

TEST(ClassifierTraining, SessionPairsAreLabelledByPosesAndRowsArePairFeatures) {
  std::vector<std::vector<double>> features;
  std::vector<llc::Pose2> poses;
  llc_test::circleKeyframes(kSet, &features, &poses);
  std::vector<llc::LabeledPair> pairs;
  const llc::TrainingSet set = circleSet(&pairs);
  ASSERT_EQ(set.size(), 120u);  // 60 per class
  ASSERT_EQ(pairs.size(), set.size());
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const llc::LabeledPair& p = pairs[i];
    const double distance = std::hypot(poses[p.a].x - poses[p.b].x, poses[p.a].y - poses[p.b].y);
    EXPECT_EQ(set.labels[i], p.label);
    if (p.label == 1) EXPECT_LT(distance, 1.5);
    else EXPECT_GT(distance, 10.0);
    const std::vector<double> row = llc::pairFeatures(kSet, features[p.a], features[p.b]);
    for (std::size_t f = 0; f < row.size(); ++f) EXPECT_EQ(set.row(i)[f], row[f]);
  }
}

TEST(ClassifierTraining, AnExcludedFeatureIsNeverAStumpsAndAnUnknownOneIsRefused) {
  const llc::TrainingSet set = circleSet();
  const llc::FeatureOptions features = paperSetOptions();
  llc::ClassifierTrainingOptions options = quickTraining();
  // The features the model leans on most without exclusion are the ones to take away.
  const llc::ClassifierTrainingResult plain = llc::trainClassifierModel(set, features, options);
  const std::vector<std::string>& names = llc::pairFeatureNames(kSet);
  std::vector<double> weight(names.size(), 0.0);
  for (const llc::Stump& stump : plain.model.classifier.stumps()) weight[std::size_t(stump.feature)] += stump.alpha;
  const std::size_t top = std::size_t(std::max_element(weight.begin(), weight.end()) - weight.begin());
  ASSERT_GT(weight[top], 0.0);
  options.excluded_features = {names[top], names[(top + 1) % names.size()]};
  const llc::ClassifierTrainingResult without = llc::trainClassifierModel(set, features, options);
  ASSERT_EQ(without.model.classifier.stumps().size(), 20u);
  for (const llc::Stump& stump : without.model.classifier.stumps()) {
    EXPECT_NE(names[std::size_t(stump.feature)], options.excluded_features[0]);
    EXPECT_NE(names[std::size_t(stump.feature)], options.excluded_features[1]);
  }
  EXPECT_EQ(without.model.provenance.at("excluded_features"), names[top] + "," + names[(top + 1) % names.size()]);
  options.excluded_features = {"no_such_feature"};
  EXPECT_THROW(llc::trainClassifierModel(set, features, options), std::invalid_argument);
}

TEST(ClassifierTraining, SeparablePairsGiveFullDetectionAndAThresholdFromHeldOutScores) {
  const llc::TrainingSet set = circleSet();
  const llc::FeatureOptions features = paperSetOptions();
  llc::ClassifierTrainingOptions options = quickTraining();
  const llc::ClassifierTrainingResult result = llc::trainClassifierModel(set, features, options);
  EXPECT_EQ(result.pairs, 120u);
  EXPECT_EQ(result.positives, 60u);
  EXPECT_EQ(result.model.classifier.stumps().size(), 20u);
  EXPECT_GE(result.detection, 0.9);  // measured 1.0
  EXPECT_GE(result.auc, 0.98);
  EXPECT_TRUE(result.model.features == features);
  const double k = result.model.classifier.thresholdK();
  EXPECT_GE(k, 0.0);
  EXPECT_LE(k, 1.0);

  // The same K as cross-validation by hand: pooled held-out scores, then the ROC.
  llc::CrossValidationOptions cv;
  cv.folds = 5;
  cv.repeats = 1;
  cv.adaboost.rounds = 20;
  const auto runs = llc::crossValidate(set, cv);
  double expected_k = -1.0;
  const double expected = llc::detectionAtFalseAlarm(runs[0].scores, set.labels, 0.01, &expected_k);
  EXPECT_DOUBLE_EQ(result.detection, expected);
  EXPECT_DOUBLE_EQ(k, expected_k);

  // A saved model reads back with the rates in its provenance.
  llc_test::TempDir dir;
  llc::saveClassifierModel(result.model, dir.file("m.yaml"));
  const llc::ClassifierModel loaded = llc::loadClassifierModel(dir.file("m.yaml"));
  EXPECT_NE(loaded.provenance.at("threshold_k").find("detection"), std::string::npos);
  EXPECT_DOUBLE_EQ(loaded.classifier.thresholdK(), k);
}

TEST(ClassifierTraining, RateModelAgreesWithTheRocOfItsScores) {
  const llc::TrainingSet set = circleSet();
  llc::AdaBoostOptions boost;
  boost.rounds = 3;
  const llc::StrongClassifier weak = llc::AdaBoostTrainer(boost).train(set).classifier;
  std::vector<double> scores;
  for (std::size_t i = 0; i < set.size(); ++i) scores.push_back(weak.score(set.row(i)));
  const llc::ModelRates rates = llc::rateModel(weak, set, 0.01);
  EXPECT_DOUBLE_EQ(rates.detection, llc::detectionAtFalseAlarm(scores, set.labels, 0.01));
  EXPECT_DOUBLE_EQ(rates.auc, llc::areaUnderCurve(scores, set.labels));
}

TEST(ClassifierTraining, BadInputIsRefusedWithAReason) {
  llc::FeatureOptions features;
  features.feature_set = kSet;
  llc::ClassifierTrainingOptions options;
  options.folds = 1;
  EXPECT_THROW(llc::trainClassifierModel(circleSet(), features, options), std::invalid_argument);
  options = {};
  // Rows of another feature set.
  llc::FeatureOptions extended;
  extended.feature_set = llc::FeatureSet::kExtended;
  EXPECT_THROW(llc::trainClassifierModel(circleSet(), extended, options), std::invalid_argument);
  // Too few pairs for ten folds.
  llc::TrainingSet tiny;
  tiny.dimension = llc::pairFeatureCount(kSet);
  std::vector<double> row(tiny.dimension, 1.0);
  tiny.add(row.data(), 1);
  tiny.add(row.data(), 0);
  EXPECT_THROW(llc::trainClassifierModel(tiny, features, options), std::invalid_argument);
  // Features and poses of different counts; a pair beyond the scans.
  EXPECT_THROW(llc::keyframeTrainingSet({{1.0}}, {}, kSet, {}), std::invalid_argument);
  EXPECT_THROW(llc::pairTrainingSet({std::vector<double>(20)}, {{0, 3, 1}}, kSet), std::out_of_range);
}

TEST(SelfLabelledTrainingSet, NeverLabelsTwoKeyframesCloserThanTheGapAsARevisit) {
  // A robot that stands still for 40 keyframes, drives 30 m away and comes back: every pair of
  // the standing keyframes is at one place, but only pairs at least the gap apart may be
  // positives (closer ones are odometry neighbours, not revisits).
  std::vector<llc::Pose2> poses;
  for (int k = 0; k < 40; ++k) poses.push_back({0.0, 0.0, 0.0});
  for (int k = 1; k <= 30; ++k) poses.push_back({double(k), 0.0, 0.0});
  for (int k = 29; k >= 0; --k) poses.push_back({double(k), 0.0, M_PI});
  std::vector<std::vector<double>> features(poses.size());
  for (std::size_t k = 0; k < poses.size(); ++k) features[k] = std::vector<double>(llc::featureCount(kSet), double(k));
  for (const std::size_t gap : {std::size_t(10), std::size_t(30)}) {
    for (const bool full_circle : {false, true}) {
      std::vector<llc::LabeledPair> pairs;
      const llc::TrainingSet set = llc::selfLabelledTrainingSet(features, poses, kSet, full_circle, gap, &pairs);
      ASSERT_EQ(set.size(), pairs.size());
      std::size_t positives = 0;
      for (const llc::LabeledPair& p : pairs) {
        const double distance = std::hypot(poses[p.b].x - poses[p.a].x, poses[p.b].y - poses[p.a].y);
        if (p.label == 1) {
          ++positives;
          EXPECT_GE(p.b - p.a, gap) << p.a << "-" << p.b;
          EXPECT_LT(distance, 1.5);
          // Partial scans: the way back (heading pi) never matches the way out (heading 0).
          if (!full_circle) {
            EXPECT_LT(std::abs(poses[p.b].theta - poses[p.a].theta), M_PI / 4);
          }
        } else {
          EXPECT_GT(distance, 10.0);
        }
      }
      EXPECT_GT(positives, 0u);
      EXPECT_EQ(2 * positives, pairs.size()) << "balanced";
    }
  }
}

}  // namespace
