// ROC, AUC, detection at a false-alarm rate and cross validation.
#include <gtest/gtest.h>

#include "laser_loop_closure/core/classifier/evaluation.hpp"
#include "laser_loop_closure/core/common/random.hpp"

namespace {

TEST(Evaluation, RocAndAucByHand) {
  // Scores 0.9(+) 0.8(-) 0.7(+) 0.6(+) 0.2(-): of the 3 x 2 (positive, negative) pairs, the
  // positive scores higher in 4 (0.9 beats both, 0.7 and 0.6 beat 0.2): AUC = 4/6.
  const std::vector<double> scores = {0.9, 0.8, 0.7, 0.6, 0.2};
  const std::vector<int> labels = {1, 0, 1, 1, 0};
  EXPECT_NEAR(llc::areaUnderCurve(scores, labels), 4.0 / 6.0, 1e-12);
  const auto roc = llc::rocCurve(scores, labels);
  ASSERT_EQ(roc.size(), 6u);
  EXPECT_NEAR(roc[1].detection, 1.0 / 3, 1e-12);
  EXPECT_NEAR(roc.back().false_alarm, 1.0, 1e-12);
  double k = 0.0;
  EXPECT_NEAR(llc::detectionAtFalseAlarm(scores, labels, 0.0, &k), 1.0 / 3, 1e-12);
  EXPECT_DOUBLE_EQ(k, 0.9);
  EXPECT_NEAR(llc::detectionAtFalseAlarm(scores, labels, 0.5, &k), 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(k, 0.6);
  const llc::ErrorRates e = llc::errorRates(scores, labels, 0.65);
  EXPECT_NEAR(e.false_alarm, 0.5, 1e-12);
  EXPECT_NEAR(e.missed_detection, 1.0 / 3, 1e-12);
}

TEST(Evaluation, TiesCountHalf) {
  EXPECT_NEAR(llc::areaUnderCurve({0.5, 0.5}, {1, 0}), 0.5, 1e-12);
}

llc::TrainingSet noisySet(std::uint64_t seed, std::size_t n) {
  llc::Random random(seed);
  llc::TrainingSet set;
  set.dimension = 3;
  for (std::size_t i = 0; i < n; ++i) {
    const int y = int(i % 2);
    const double row[3] = {random.uniform() + 0.8 * y, random.uniform(), random.uniform() - 0.3 * y};
    set.add(row, y);
  }
  return set;
}

TEST(Evaluation, CrossValidationIsSeededAndSensible) {
  const llc::TrainingSet set = noisySet(11, 400);
  llc::CrossValidationOptions options;
  options.repeats = 2;
  options.adaboost.rounds = 20;
  const auto a = llc::crossValidate(set, options);
  const auto b = llc::crossValidate(set, options);
  ASSERT_EQ(a.size(), 2u);
  EXPECT_EQ(a[0].scores, b[0].scores);     // same seed, same result
  EXPECT_NE(a[0].scores, a[1].scores);     // a new shuffle per repeat
  const llc::CrossValidationSummary s = llc::summarize(a, set.labels);
  EXPECT_GT(s.auc, 0.85);  // feature 0 separates the classes well
  EXPECT_LT(s.auc, 1.0);
  EXPECT_GE(s.detection_at_1pct, 0.0);
  EXPECT_EQ(s.roc_false_alarm.size(), 1001u);
  EXPECT_NEAR(s.roc_detection.back(), 1.0, 1e-12);
}

TEST(Evaluation, ErrorCurvesAndAblation) {
  const llc::TrainingSet set = noisySet(12, 200);
  const auto curve = llc::errorByRounds(set, 30, 5, 1, 1);
  ASSERT_EQ(curve.size(), 30u);
  for (const auto& e : curve) EXPECT_LT(e.total(), 1.0);
  llc::CrossValidationOptions options;
  options.folds = 5;
  options.repeats = 1;
  options.adaboost.rounds = 10;
  const auto without = llc::errorWithoutEachFeature(set, options);
  ASSERT_EQ(without.size(), 3u);
  // Removing the informative feature 0 hurts more than removing the noise feature 1.
  EXPECT_GT(without[0].total(), without[1].total());
}

TEST(Evaluation, RefusesTooFewPairs) {
  llc::CrossValidationOptions options;
  EXPECT_THROW(llc::crossValidate(noisySet(1, 6), options), std::invalid_argument);
  options.folds = 1;
  EXPECT_THROW(llc::crossValidate(noisySet(1, 100), options), std::invalid_argument);
}

}  // namespace
