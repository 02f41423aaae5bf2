// Leave-one-log-out: the held-out log never reaches the fitter, and the figures of each held-out
// log are worked out by hand on one-feature logs.
#include <gtest/gtest.h>

#include <set>

#include "laser_loop_closure/core/classifier/log_out_evaluation.hpp"

namespace {

/// A one-feature log whose rows carry `marker + i` (so a row tells which log it came from).
llc::TrainingSet markedLog(double marker, int positives, int negatives) {
  llc::TrainingSet set;
  set.dimension = 1;
  for (int i = 0; i < positives + negatives; ++i) {
    const double value = marker + i;
    set.add(&value, i < positives ? 1 : 0);
  }
  return set;
}

/// A one-feature log from values and labels.
llc::TrainingSet oneFeatureLog(const std::vector<double>& values, const std::vector<int>& labels) {
  llc::TrainingSet set;
  set.dimension = 1;
  for (std::size_t i = 0; i < values.size(); ++i) set.add(&values[i], labels[i]);
  return set;
}

/// One stump: match iff feature < 0.5 (a small difference means the same place), K = 0.5.
llc::StrongClassifier smallDifferenceModel() {
  llc::Stump stump;
  stump.feature = 0;
  stump.polarity = 1;
  stump.threshold = 0.5;
  stump.alpha = 1.0;
  return llc::StrongClassifier({stump}, 0.5);
}

TEST(LeaveOneLogOut, TheHeldOutLogNeverReachesTheFitter) {
  const std::vector<llc::TrainingSet> logs = {markedLog(1000, 3, 5), markedLog(2000, 4, 4), markedLog(3000, 2, 6)};
  std::vector<std::set<int>> seen_logs;  // per fit: which logs' rows it was given
  const llc::ClassifierFitter fit = [&](const llc::TrainingSet& training, const std::vector<llc::TrainingSet>&) {
    std::set<int> from;
    for (double v : training.features) from.insert(int(v) / 1000);
    seen_logs.push_back(from);
    return llc::StrongClassifier();
  };
  const llc::LeaveOneLogOutResult result = llc::leaveOneLogOut(logs, {"a", "b", "c"}, fit);
  ASSERT_EQ(seen_logs.size(), 3u);
  EXPECT_EQ(seen_logs[0], (std::set<int>{2, 3}));
  EXPECT_EQ(seen_logs[1], (std::set<int>{1, 3}));
  EXPECT_EQ(seen_logs[2], (std::set<int>{1, 2}));
  EXPECT_EQ(result.logs[0].training_pairs, 16u);
  EXPECT_EQ(result.logs[1].training_pairs, 16u);
  EXPECT_EQ(result.logs[2].training_pairs, 16u);
  EXPECT_EQ(result.logs[1].name, "b");
  EXPECT_EQ(result.logs[2].pairs, 8u);
  EXPECT_EQ(result.logs[2].positives, 2u);
}

TEST(LeaveOneLogOut, FiguresOfAHeldOutLogAtTheModelsOwnK) {
  const llc::StrongClassifier model = smallDifferenceModel();
  const auto log = oneFeatureLog;
  // Log A: 2 positives matched, 1 missed; 1 of 4 negatives matched.
  const llc::TrainingSet a = log({0.1, 0.2, 0.9, 0.3, 0.8, 0.9, 1.0}, {1, 1, 1, 0, 0, 0, 0});
  // Log B: everything right.
  const llc::TrainingSet b = log({0.1, 0.7, 0.8}, {1, 0, 0});
  const llc::LeaveOneLogOutResult result = llc::leaveOneLogOut({a, b}, {}, [&](const llc::TrainingSet&, const std::vector<llc::TrainingSet>&) { return model; });
  ASSERT_EQ(result.logs.size(), 2u);
  const llc::HeldOutLog& ra = result.logs[0];
  EXPECT_EQ(ra.name, "log 1");
  EXPECT_DOUBLE_EQ(ra.k, 0.5);
  EXPECT_NEAR(ra.detection_at_k, 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(ra.realised_false_alarm, 0.25, 1e-12);
  // Scores are 1 (match) or 0: at <= 1% false alarm only K above 1 is allowed, detection 0.
  EXPECT_DOUBLE_EQ(ra.detection_at_1pct, 0.0);
  // AUC: the 1-scores hold 2 of 3 positives and 1 of 4 negatives; ties count one half.
  EXPECT_NEAR(ra.auc, 2.0 / 3.0 * 0.75 + 0.5 * (2.0 / 3.0 * 0.25) + 0.5 * (1.0 / 3.0 * 0.75), 1e-12);
  const llc::HeldOutLog& rb = result.logs[1];
  EXPECT_DOUBLE_EQ(rb.detection_at_k, 1.0);
  EXPECT_DOUBLE_EQ(rb.realised_false_alarm, 0.0);
  EXPECT_DOUBLE_EQ(rb.detection_at_0pct, 1.0);
  EXPECT_DOUBLE_EQ(rb.auc, 1.0);
  EXPECT_NEAR(result.mean_realised_false_alarm, 0.125, 1e-12);
  EXPECT_NEAR(result.worst_realised_false_alarm, 0.25, 1e-12);
  EXPECT_NEAR(result.mean_detection_at_k, (2.0 / 3.0 + 1.0) / 2.0, 1e-12);
}

TEST(LeaveOneLogOut, ExtraNegativesOnlyRefineTheRealisedFalseAlarmRate) {
  const llc::StrongClassifier model = smallDifferenceModel();
  const auto log = oneFeatureLog;
  const llc::TrainingSet a = log({0.1, 0.2, 0.9, 0.3, 0.8, 0.9, 1.0}, {1, 1, 1, 0, 0, 0, 0});  // 1 of 4 negatives matched
  const llc::TrainingSet b = log({0.1, 0.7, 0.8}, {1, 0, 0});
  // Six more negatives of log A, one of them matched: 2 of 10 in all. None for log B.
  const std::vector<llc::TrainingSet> extra = {log({0.1, 0.9, 0.9, 0.9, 0.9, 0.9}, {0, 0, 0, 0, 0, 0}), log({}, {})};
  std::size_t fits = 0;
  const llc::LeaveOneLogOutResult result = llc::leaveOneLogOut({a, b}, {}, [&](const llc::TrainingSet& training, const std::vector<llc::TrainingSet>&) {
    ++fits;
    EXPECT_TRUE(training.size() == 3u || training.size() == 7u) << "extra negatives never reach the fitter: " << training.size();
    return model;
  }, &extra);
  EXPECT_EQ(fits, 2u);
  EXPECT_EQ(result.logs[0].false_alarm_negatives, 10u);
  EXPECT_NEAR(result.logs[0].realised_false_alarm, 0.2, 1e-12);
  EXPECT_NEAR(result.logs[0].detection_at_k, 2.0 / 3.0, 1e-12);  // positives untouched
  EXPECT_EQ(result.logs[1].false_alarm_negatives, 2u);
  EXPECT_DOUBLE_EQ(result.logs[1].realised_false_alarm, 0.0);

  const std::vector<llc::TrainingSet> one_set = {extra[0]};
  EXPECT_THROW(llc::leaveOneLogOut({a, b}, {}, [&](const llc::TrainingSet&, const std::vector<llc::TrainingSet>&) { return model; }, &one_set), std::invalid_argument);
  const std::vector<llc::TrainingSet> a_positive = {log({0.1}, {1}), log({}, {})};
  EXPECT_THROW(llc::leaveOneLogOut({a, b}, {}, [&](const llc::TrainingSet&, const std::vector<llc::TrainingSet>&) { return model; }, &a_positive), std::invalid_argument);
}

TEST(LeaveOneLogOut, RefusesOneLogAndMixedDimensions) {
  const llc::ClassifierFitter fit = [](const llc::TrainingSet&, const std::vector<llc::TrainingSet>&) { return llc::StrongClassifier(); };
  EXPECT_THROW(llc::leaveOneLogOut({markedLog(0, 2, 2)}, {}, fit), std::invalid_argument);
  llc::TrainingSet two_dimensions;
  two_dimensions.dimension = 2;
  EXPECT_THROW(llc::leaveOneLogOut({markedLog(0, 2, 2), two_dimensions}, {}, fit), std::invalid_argument);
}

}  // namespace
