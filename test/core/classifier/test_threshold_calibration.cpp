// Threshold calibration from surely-different pairs: hand-worked thresholds, the odometry rule,
// the pair sampler on a straight drive, the running calibrator, and its use held out.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>

#include "laser_loop_closure/core/classifier/log_out_evaluation.hpp"
#include "laser_loop_closure/core/classifier/threshold_calibration.hpp"

namespace {

const double kNan = std::numeric_limits<double>::quiet_NaN();

TEST(ThresholdForFalseAlarm, LetsThroughAtMostTheTargetShare) {
  const std::vector<double> scores = {0.3, 0.1, 1.0, 0.5, 0.2, 0.9, 0.4, 0.7, 0.6, 0.8};
  // 10% of 10: one score may reach K, so K lies just above the second largest (0.9).
  const double k10 = llc::thresholdForFalseAlarm(scores, 0.1);
  EXPECT_GT(k10, 0.9);
  EXPECT_LT(k10, 0.9 + 1e-12);
  // 25%: floor(2.5) = 2 may reach K: just above 0.8.
  const double k25 = llc::thresholdForFalseAlarm(scores, 0.25);
  EXPECT_GT(k25, 0.8);
  EXPECT_LT(k25, 0.9);
  // 1% of 10 is no score at all: K above the largest.
  EXPECT_GT(llc::thresholdForFalseAlarm(scores, 0.01), 1.0);
  // Ties: with 0.5 four times, letting one through means letting none.
  EXPECT_GT(llc::thresholdForFalseAlarm({0.5, 0.5, 0.5, 0.5, 0.1}, 0.2), 0.5);
  EXPECT_THROW(llc::thresholdForFalseAlarm({}, 0.01), std::invalid_argument);
}

TEST(SurelyDifferentPlaces, FartherThanTheDistancePlusTheDriftOfThePath) {
  llc::ThresholdCalibrationOptions options;  // 10 m + 0.3 m per metre driven, at most 50 m driven
  const llc::Pose2 a{0, 0, 0}, b{20, 0, 1};
  EXPECT_TRUE(llc::surelyDifferentPlaces(a, b, 30.0, options));    // 20 > 10 + 9
  EXPECT_FALSE(llc::surelyDifferentPlaces(a, b, 40.0, options));   // 20 < 10 + 12
  EXPECT_FALSE(llc::surelyDifferentPlaces(a, b, 60.0, options));   // driven too far to bound the drift
  EXPECT_FALSE(llc::surelyDifferentPlaces(a, {kNan, 0, 0}, 1.0, options));
  EXPECT_FALSE(llc::surelyDifferentPlaces(a, b, kNan, options));
  EXPECT_FALSE(llc::surelyDifferentPlaces(a, b, -1.0, options));
}

TEST(SampleSurelyDifferentPairs, AStraightDriveGivesEveryPairOfTheRightSeparation) {
  std::vector<llc::Pose2> line;
  for (int i = 0; i < 100; ++i) line.push_back({double(i), 0.0, 0.0});
  const std::vector<double> path = llc::pathLengths(line);
  EXPECT_DOUBLE_EQ(path[0], 0.0);
  EXPECT_DOUBLE_EQ(path[99], 99.0);
  llc::ThresholdCalibrationOptions options;
  // d metres apart and d driven: surely different when d > 10 + 0.3 d (d >= 15) and d <= 50.
  std::size_t expected = 0;
  for (int d = 15; d <= 50; ++d) expected += 100 - d;
  ASSERT_EQ(expected, 2430u);
  const std::vector<llc::LabeledPair> all = llc::sampleSurelyDifferentPairs(line, options, 100000, 7);
  EXPECT_EQ(all.size(), expected);
  std::set<std::pair<std::size_t, std::size_t>> distinct;
  for (const llc::LabeledPair& p : all) {
    EXPECT_LT(p.a, p.b);
    EXPECT_EQ(p.label, 0);
    EXPECT_GE(p.b - p.a, 15u);
    EXPECT_LE(p.b - p.a, 50u);
    distinct.insert({p.a, p.b});
  }
  EXPECT_EQ(distinct.size(), all.size());
  const std::vector<llc::LabeledPair> some = llc::sampleSurelyDifferentPairs(line, options, 100, 7);
  const std::vector<llc::LabeledPair> again = llc::sampleSurelyDifferentPairs(line, options, 100, 7);
  ASSERT_EQ(some.size(), 100u);
  for (std::size_t i = 0; i < some.size(); ++i) EXPECT_TRUE(some[i].a == again[i].a && some[i].b == again[i].b);
  options.max_path = 10.0;  // nothing 10 m driven is more than 10 m away
  EXPECT_TRUE(llc::sampleSurelyDifferentPairs(line, options, 100, 7).empty());
  options.max_path = -1.0;
  EXPECT_THROW(llc::sampleSurelyDifferentPairs(line, options, 100, 7), std::invalid_argument);
}

TEST(ThresholdCalibrator, TheModelsKUntilEnoughPairsThenTheirQuantile) {
  llc::ThresholdCalibrationOptions options;
  options.enabled = true;
  options.min_pairs = 100;
  options.max_pairs = 200;
  options.target_false_alarm = 0.05;
  llc::ThresholdCalibrator calibrator(options);
  for (int i = 0; i < 99; ++i) calibrator.add(i / 100.0);
  calibrator.add(kNan);  // ignored
  EXPECT_EQ(calibrator.seen(), 99u);
  EXPECT_FALSE(calibrator.calibrated());
  EXPECT_DOUBLE_EQ(calibrator.threshold(0.42), 0.42);
  calibrator.add(0.99);  // 0.00 .. 0.99: 5 of 100 may reach K, so K lies just above 0.94
  EXPECT_TRUE(calibrator.calibrated());
  const double k = calibrator.threshold(0.42);
  EXPECT_GT(k, 0.94);
  EXPECT_LT(k, 0.95);
  // Beyond max_pairs the reservoir keeps 200 scores; a flood of low scores pulls K down.
  for (int i = 0; i < 10000; ++i) calibrator.add(0.0);
  EXPECT_EQ(calibrator.seen(), 10100u);
  EXPECT_LT(calibrator.threshold(0.42), 0.5);
  calibrator.clear();
  EXPECT_FALSE(calibrator.calibrated());
  EXPECT_DOUBLE_EQ(calibrator.threshold(0.42), 0.42);
  options.enabled = false;
  llc::ThresholdCalibrator off(options);
  for (int i = 0; i < 1000; ++i) off.add(0.1);
  EXPECT_DOUBLE_EQ(off.threshold(0.42), 0.42);
  options = {};
  options.target_false_alarm = 1.0;
  EXPECT_THROW(llc::ThresholdCalibrator{options}, std::invalid_argument);
  options = {};
  options.max_pairs = options.min_pairs - 1;
  EXPECT_THROW(llc::ThresholdCalibrator{options}, std::invalid_argument);
}

/// A one-feature log from values and labels.
llc::TrainingSet oneFeatureLog(const std::vector<double>& values, const std::vector<int>& labels) {
  llc::TrainingSet set;
  set.dimension = 1;
  for (std::size_t i = 0; i < values.size(); ++i) set.add(&values[i], labels[i]);
  return set;
}

TEST(LeaveOneLogOut, CalibrationPairsSetTheHeldOutLogsOwnK) {
  // Two stumps: a difference below 0.25 scores 1, below 0.5 scores 0.5, else 0; K = 0.5.
  llc::Stump loose, tight;
  loose.feature = tight.feature = 0;
  loose.polarity = tight.polarity = 1;
  loose.threshold = 0.5, tight.threshold = 0.25;
  loose.alpha = tight.alpha = 1.0;
  const llc::StrongClassifier model({loose, tight}, 0.5);
  // Log A: positives score 1, 0.5, 0; negatives 0.5, 0.5, 0, 0: at K = 0.5 half the negatives pass.
  const llc::TrainingSet a = oneFeatureLog({0.1, 0.3, 0.9, 0.3, 0.3, 0.9, 0.9}, {1, 1, 1, 0, 0, 0, 0});
  const llc::TrainingSet b = oneFeatureLog({0.1, 0.7}, {1, 0});
  // A's own surely-different pairs: one of ten scores 0.5, so K for 1% lies just above 0.5.
  const std::vector<llc::TrainingSet> calibration = {
      oneFeatureLog({0.3, 0.9, 0.9, 0.9, 0.9, 0.9, 0.9, 0.9, 0.9, 0.9}, std::vector<int>(10, 0)), oneFeatureLog({}, {})};
  llc::LogOutCalibration at_one_percent;
  at_one_percent.pairs = &calibration;
  at_one_percent.target_false_alarm = 0.01;
  const llc::LeaveOneLogOutResult result = llc::leaveOneLogOut({a, b}, {}, [&](const llc::TrainingSet& training, const std::vector<llc::TrainingSet>&) {
    EXPECT_TRUE(training.size() == 2u || training.size() == 7u) << "calibration pairs never reach the fitter: " << training.size();
    return model;
  }, nullptr, &at_one_percent);
  const llc::HeldOutLog& ra = result.logs[0];
  EXPECT_NEAR(ra.realised_false_alarm, 0.5, 1e-12);
  EXPECT_NEAR(ra.detection_at_k, 2.0 / 3.0, 1e-12);
  EXPECT_EQ(ra.calibration_pairs, 10u);
  EXPECT_GT(ra.calibrated_k, 0.5);
  EXPECT_DOUBLE_EQ(ra.realised_false_alarm_calibrated, 0.0);
  EXPECT_NEAR(ra.detection_at_calibrated_k, 1.0 / 3.0, 1e-12);
  EXPECT_EQ(result.logs[1].calibration_pairs, 0u);  // no pairs: nothing calibrated
  EXPECT_DOUBLE_EQ(result.worst_realised_false_alarm_calibrated, 0.0);
  const std::vector<llc::TrainingSet> one_set = {calibration[0]};
  llc::LogOutCalibration too_few = at_one_percent;
  too_few.pairs = &one_set;
  EXPECT_THROW(llc::leaveOneLogOut({a, b}, {}, [&](const llc::TrainingSet&, const std::vector<llc::TrainingSet>&) { return model; }, nullptr, &too_few),
               std::invalid_argument);
}

TEST(ThresholdCalibration, RaiseOnlyNeverLowersTheModelsK) {
  // Ten scores; 1.5% of ten allows none through: K just above the largest, 0.4.
  const std::vector<double> scores = {0.1, 0.2, 0.4, 0.3, 0.1, 0.2, 0.3, 0.1, 0.2, 0.3};
  llc::ThresholdCalibrationOptions options;
  EXPECT_DOUBLE_EQ(options.target_false_alarm, 0.015);
  EXPECT_TRUE(options.raise_only);
  const double fitted = std::nextafter(0.4, 1.0);
  EXPECT_DOUBLE_EQ(llc::calibratedThreshold(scores, 0.6, options), 0.6);     // a building less alike: the model's K stays
  EXPECT_DOUBLE_EQ(llc::calibratedThreshold(scores, 0.3, options), fitted);  // more alike: K rises
  options.raise_only = false;
  EXPECT_DOUBLE_EQ(llc::calibratedThreshold(scores, 0.6, options), fitted);  // up or down
  // The calibrator as a drive runs it: the model's K until min_pairs scores, then the floor holds.
  options.raise_only = true;
  options.enabled = true;
  options.min_pairs = 10;
  llc::ThresholdCalibrator calibrator(options);
  for (std::size_t i = 0; i + 1 < scores.size(); ++i) calibrator.add(scores[i]);
  EXPECT_DOUBLE_EQ(calibrator.threshold(0.35), 0.35);
  calibrator.add(scores.back());
  EXPECT_DOUBLE_EQ(calibrator.threshold(0.35), fitted);
  EXPECT_DOUBLE_EQ(calibrator.threshold(0.7), 0.7);
}

/// One positive (0.1) and `negatives` negatives of which one passes a model matching below
/// 0.5 (0.3; the others 0.9): realised false alarm 1 / negatives at that model's K.
llc::TrainingSet logWithNegatives(int negatives) {
  std::vector<double> values = {0.1, 0.3};
  std::vector<int> labels = {1, 0};
  for (int i = 1; i < negatives; ++i) values.push_back(0.9), labels.push_back(0);
  return oneFeatureLog(values, labels);
}

/// 100 calibration pairs, `high` of them passing that model (score 1), the rest scoring 0.
llc::TrainingSet calibrationPairs(int high) {
  std::vector<double> values;
  for (int i = 0; i < 100; ++i) values.push_back(i < high ? 0.1 : 0.9);
  return oneFeatureLog(values, std::vector<int>(100, 0));
}

TEST(LeaveOneLogOut, TheCalibrationTargetIsChosenOnTheOtherLogsByModelsThatNeverSawThem) {
  // Logs of 11, 12 and 13 rows: a fit's training size tells which logs it was given.
  const std::vector<llc::TrainingSet> logs = {logWithNegatives(10), logWithNegatives(11), logWithNegatives(12)};
  std::vector<std::size_t> fit_sizes;
  const llc::ClassifierFitter fit = [&](const llc::TrainingSet& training, const std::vector<llc::TrainingSet>&) {
    fit_sizes.push_back(training.size());
    llc::Stump stump;
    stump.feature = 0, stump.polarity = 1, stump.threshold = 0.5, stump.alpha = 1.0;
    return llc::StrongClassifier({stump}, 0.5);
  };
  // At target t, floor(100 t) pairs may pass: with fewer than `high` allowed, K is lifted above
  // 1 (realised 0%); else K stays at the model's 0.5 (raise_only; realised 1/10, 1/11, 1/12).
  // A band of 5-20% is kept only where K is not lifted: t >= 0.02 for high = 2, t >= 0.01 for 1.
  const std::vector<llc::TrainingSet> pairs = {calibrationPairs(2), calibrationPairs(1), calibrationPairs(1)};
  llc::LogOutCalibration calibration;
  calibration.pairs = &pairs;
  calibration.candidate_targets = {0.03, 0.005, 0.01};
  calibration.band_low = 0.05, calibration.band_high = 0.2;
  const llc::LeaveOneLogOutResult result = llc::leaveOneLogOut(logs, {}, fit, nullptr, &calibration);
  // Per held-out log: its model (the two others), then one per other log (the third alone).
  EXPECT_EQ(fit_sizes, (std::vector<std::size_t>{25, 13, 12, 24, 13, 11, 23, 12, 11}));
  // Log 0's others both have high = 1: 0.01 is the smallest keeping them in the band; its own
  // pairs (high = 2) then lift K. Logs 1 and 2 see log 0 (high = 2) among theirs: 0.03.
  EXPECT_DOUBLE_EQ(result.logs[0].calibration_target, 0.01);
  EXPECT_GT(result.logs[0].calibrated_k, 1.0);
  EXPECT_DOUBLE_EQ(result.logs[0].realised_false_alarm_calibrated, 0.0);
  for (std::size_t i : {1, 2}) {
    EXPECT_DOUBLE_EQ(result.logs[i].calibration_target, 0.03);
    EXPECT_DOUBLE_EQ(result.logs[i].calibrated_k, 0.5);
    EXPECT_DOUBLE_EQ(result.logs[i].realised_false_alarm_calibrated, result.logs[i].realised_false_alarm);
  }
  EXPECT_NEAR(result.logs[1].realised_false_alarm, 1.0 / 11.0, 1e-12);
  // With two logs no model is left to choose on: refused.
  const std::vector<llc::TrainingSet> two_pairs = {pairs[0], pairs[1]};
  calibration.pairs = &two_pairs;
  EXPECT_THROW(llc::leaveOneLogOut({logs[0], logs[1]}, {}, fit, nullptr, &calibration), std::invalid_argument);
}

}  // namespace
