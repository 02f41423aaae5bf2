// Training-pair augmentation: scans resampled by hand-worked values, the kinds' names parsed,
// and augmented rows that train with their own row's folds only (never scored, never beside
// the held-out form of their pair).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>

#include "laser_loop_closure/core/classifier/augmentation.hpp"
#include "laser_loop_closure/core/classifier/classifier_training.hpp"
#include "laser_loop_closure/core/classifier/evaluation.hpp"
#include "laser_loop_closure/core/classifier/log_out_evaluation.hpp"
#include "laser_loop_closure/core/common/random.hpp"

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

llc::Scan scanOf(std::vector<double> ranges, std::vector<double> bearings, bool full_circle = false) {
  llc::Scan scan;
  scan.ranges = std::move(ranges);
  scan.bearings = std::move(bearings);
  scan.full_circle = full_circle;
  scan.stamp = 4.5;
  return scan;
}

TEST(Augmentation, HalfBeamsKeepsEverySecondBeamFromTheFirst) {
  const llc::Scan half = llc::halfBeams(scanOf({1, 2, 3, 4, 5}, {-0.2, -0.1, 0.0, 0.1, 0.2}));
  EXPECT_EQ(half.ranges, (std::vector<double>{1, 3, 5}));
  EXPECT_EQ(half.bearings, (std::vector<double>{-0.2, 0.0, 0.2}));
  EXPECT_EQ(half.stamp, 4.5);
  EXPECT_TRUE(llc::halfBeams(llc::Scan{}).empty());
}

TEST(Augmentation, DoubleBeamsInterpolatesOneSurfaceAndKeepsEdgesAndGaps) {
  // 1 and 1.1 are one surface (mean), 1.1 and 3 an edge (the nearer hides the farther), 3 and
  // inf a gap (no return).
  const llc::Scan doubled = llc::doubleBeams(scanOf({1.0, 1.1, 3.0, kInf}, {0.0, 0.1, 0.2, 0.3}), 0.2);
  ASSERT_EQ(doubled.size(), 7u);
  const std::vector<double> ranges = {1.0, 1.05, 1.1, 1.1, 3.0, kInf, kInf};
  const std::vector<double> bearings = {0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3};
  for (std::size_t i = 0; i < 7; ++i) {
    EXPECT_DOUBLE_EQ(doubled.ranges[i], ranges[i]) << i;
    EXPECT_DOUBLE_EQ(doubled.bearings[i], bearings[i]) << i;
  }
  // A NaN (invalid) beam stays one: the new beam beside it is invalid too.
  const llc::Scan with_nan = llc::doubleBeams(scanOf({std::nan(""), 2.0}, {0.0, 0.1}));
  ASSERT_EQ(with_nan.size(), 3u);
  EXPECT_TRUE(std::isnan(with_nan.ranges[1]));
}

TEST(Augmentation, DoubleBeamsOfAFullCircleClosesTheRingInIncreasingBearings) {
  const double q = M_PI / 4;
  const llc::Scan doubled = llc::doubleBeams(scanOf({2, 2, 2, 2}, {-3 * q, -q, q, 3 * q}, true));
  ASSERT_EQ(doubled.size(), 8u);
  // The beam between the last (3 pi/4) and the first (-3 pi/4, a turn on) lies at pi: it goes first, at -pi.
  EXPECT_NEAR(doubled.bearings.front(), -M_PI, 1e-12);
  for (std::size_t i = 1; i < doubled.size(); ++i) EXPECT_NEAR(doubled.bearings[i] - doubled.bearings[i - 1], q, 1e-12) << i;
  EXPECT_LT(doubled.bearings.back(), M_PI);
  // Not a full circle: no beam after the last.
  EXPECT_EQ(llc::doubleBeams(scanOf({2, 2, 2, 2}, {-3 * q, -q, q, 3 * q}, false)).size(), 7u);
}

TEST(Augmentation, BadScansGiveFiniteFeaturesEitherWay) {
  const double nan = std::nan("");
  llc::FeatureExtractor extractor;
  const std::vector<llc::Scan> bad = {
      llc::Scan{},
      scanOf({3.0}, {0.0}),
      scanOf({nan, kInf, -kInf, -1.0, 0.0, 2.0}, {-0.2, -0.1, 0.0, 0.1, 0.2, 0.3}),
      scanOf({1.0, 2.0, 3.0, 4.0}, {0.0, nan, kInf, 0.3}),
      scanOf({1.0, 2.0, 3.0}, {0.0, 0.1}),  // fewer bearings than ranges: the common part
      scanOf({2.0, 2.0, 2.0}, {-3.0, 0.0, 3.0}, true)};
  for (std::size_t k = 0; k < bad.size(); ++k)
    for (const llc::ScanAugmentation kind : {llc::ScanAugmentation::kHalfBeams, llc::ScanAugmentation::kDoubleBeams}) {
      const llc::Scan resampled = llc::augmentScan(bad[k], kind);
      EXPECT_EQ(resampled.ranges.size(), resampled.bearings.size()) << k;
      for (const double v : extractor.extract(resampled)) EXPECT_TRUE(std::isfinite(v)) << k;
    }
}

TEST(Augmentation, KindsAreParsedByNameAndABadListIsRefused) {
  EXPECT_TRUE(llc::parseScanAugmentations("").empty());
  EXPECT_TRUE(llc::parseScanAugmentations("none").empty());
  EXPECT_EQ(llc::parseScanAugmentations("double-beams,half-beams"),
            (std::vector<llc::ScanAugmentation>{llc::ScanAugmentation::kDoubleBeams, llc::ScanAugmentation::kHalfBeams}));
  EXPECT_THROW(llc::parseScanAugmentations("half-beams,quarter-beams"), std::invalid_argument);
  EXPECT_THROW(llc::parseScanAugmentations("half-beams,half-beams"), std::invalid_argument);
  EXPECT_THROW(llc::parseScanAugmentations(","), std::invalid_argument);
  EXPECT_STREQ(llc::scanAugmentationName(llc::ScanAugmentation::kHalfBeams), "half-beams");
}

TEST(Augmentation, APairSetDescribesOnlyTheNamedScansResampled) {
  llc::ScanSequence log;
  for (int k = 0; k < 3; ++k) {
    llc::LoggedScan s;
    for (int i = 0; i < 181; ++i) {
      s.scan.bearings.push_back(-M_PI / 2 + M_PI * i / 180.0);
      s.scan.ranges.push_back(2.0 + 0.5 * k + std::sin(0.1 * i));
    }
    log.scans.push_back(s);
  }
  llc::FeatureExtractor extractor;
  const std::vector<llc::LabeledPair> pairs = {{0, 2, 1}, {1, 2, 0}};
  const llc::TrainingSet half = llc::augmentedPairSet(log, pairs, llc::ScanAugmentation::kHalfBeams, extractor);
  ASSERT_EQ(half.size(), 2u);
  EXPECT_EQ(half.labels, (std::vector<int>{1, 0}));
  // Row 0 by hand: the pair features of the two resampled scans' features.
  const std::vector<double> a = extractor.extract(llc::halfBeams(log.scans[0].scan));
  const std::vector<double> b = extractor.extract(llc::halfBeams(log.scans[2].scan));
  const std::vector<double> row = llc::pairFeatures(extractor.options().feature_set, a, b);
  ASSERT_EQ(row.size(), half.dimension);
  for (std::size_t i = 0; i < row.size(); ++i) EXPECT_EQ(half.row(0)[i], row[i]) << i;
  EXPECT_THROW(llc::augmentedPairSet(log, {{0, 3, 1}}, llc::ScanAugmentation::kHalfBeams, extractor), std::invalid_argument);
}

/// Rows with no signal (random values, random labels): a fold's classifier can score a row
/// well only by having seen it.
llc::TrainingSet noise(std::size_t rows, std::uint64_t seed) {
  llc::Random random(seed);
  llc::TrainingSet set;
  set.dimension = 4;
  for (std::size_t i = 0; i < rows; ++i) {
    const double v[4] = {random.uniform(), random.uniform(), random.uniform(), random.uniform()};
    set.add(v, i % 2 == 0 ? 1 : 0);
  }
  return set;
}

double pooledAuc(const std::vector<llc::CrossValidationRun>& runs, const std::vector<int>& labels) {
  std::vector<double> scores;
  std::vector<int> all;
  for (const auto& run : runs) scores.insert(scores.end(), run.scores.begin(), run.scores.end()), all.insert(all.end(), labels.begin(), labels.end());
  return llc::areaUnderCurve(scores, all);
}

TEST(Augmentation, ACompanionRowTrainsOnlyWithItsOwnRowsFolds) {
  const llc::TrainingSet data = noise(200, 3);
  llc::CrossValidationOptions cv;
  cv.folds = 5;
  cv.repeats = 2;
  cv.adaboost.rounds = 100;
  // Companions that are copies of their rows: a fold that trained on the copy of a row it
  // scores would know its label. Kept with their rows, the scores stay chance.
  const std::vector<llc::TrainingSet> copies = {data};
  const double kept = pooledAuc(llc::crossValidate(data, cv, nullptr, &copies), data.labels);
  EXPECT_LT(std::abs(kept - 0.5), 0.1) << kept;
  // The reference: the same copies merely appended as more rows leak into the test folds.
  llc::TrainingSet appended = data;
  appended.append(data);
  const auto leaked_runs = llc::crossValidate(appended, cv);
  std::vector<llc::CrossValidationRun> first_half = leaked_runs;
  for (auto& run : first_half) run.scores.resize(data.size());
  EXPECT_GT(pooledAuc(first_half, data.labels), kept + 0.1);
  const std::vector<llc::TrainingSet> short_copies = {noise(10, 3)};
  EXPECT_THROW(llc::crossValidate(data, cv, nullptr, &short_copies), std::invalid_argument);
}

TEST(Augmentation, TrainingWithCompanionsRecordsThemAndRefusesAMismatch) {
  const llc::TrainingSet data = noise(60, 5);
  llc::FeatureOptions features;
  features.feature_set = llc::FeatureSet::kPaper;
  llc::TrainingSet wide;  // the paper set's pair rows: features of noise, padded
  wide.dimension = llc::pairFeatureCount(features.feature_set);
  std::vector<double> row(wide.dimension, 0.0);
  for (std::size_t i = 0; i < data.size(); ++i) {
    std::copy(data.row(i), data.row(i) + data.dimension, row.begin());
    wide.add(row.data(), data.labels[i]);
  }
  llc::ClassifierTrainingOptions options;
  options.rounds = 10;
  options.folds = 3;
  const std::vector<llc::TrainingSet> companions = {wide, wide};
  const llc::ClassifierTrainingResult trained = llc::trainClassifierModel(wide, features, options, &companions);
  EXPECT_EQ(trained.model.provenance.at("augmented_rows"), "120");
  EXPECT_EQ(trained.model.provenance.at("pairs"), "60");
  EXPECT_EQ(llc::trainClassifierModel(wide, features, options).model.provenance.count("augmented_rows"), 0u);
  llc::TrainingSet shorter = wide.subset({0, 1, 2});
  const std::vector<llc::TrainingSet> bad = {shorter};
  EXPECT_THROW(llc::trainClassifierModel(wide, features, options, &bad), std::invalid_argument);
}

TEST(Augmentation, LeaveOneLogOutGivesEachFitTheAugmentedRowsOfItsTrainingLogsOnly) {
  auto marked = [](double marker, std::size_t rows) {
    llc::TrainingSet set;
    set.dimension = 1;
    for (std::size_t i = 0; i < rows; ++i) {
      const double v = marker + double(i);
      set.add(&v, int(i % 2));
    }
    return set;
  };
  const std::vector<llc::TrainingSet> logs = {marked(1000, 4), marked(2000, 6), marked(3000, 8)};
  // One kind; its rows carry the log's marker plus 500.
  const llc::LogOutAugmentation augmentation = {{marked(1500, 4), marked(2500, 6), marked(3500, 8)}};
  std::vector<std::set<int>> seen;
  const llc::ClassifierFitter fit = [&](const llc::TrainingSet& training, const std::vector<llc::TrainingSet>& companions) {
    EXPECT_EQ(companions.size(), 1u);
    EXPECT_EQ(companions.front().size(), training.size());
    std::set<int> from;
    for (double v : companions.front().features) from.insert(int(v) / 500);
    seen.push_back(from);
    return llc::StrongClassifier();
  };
  llc::leaveOneLogOut(logs, {}, fit, nullptr, nullptr, &augmentation);
  ASSERT_EQ(seen.size(), 3u);
  EXPECT_EQ(seen[0], (std::set<int>{5, 7}));  // 2500.., 3500.. : logs 2 and 3
  EXPECT_EQ(seen[1], (std::set<int>{3, 7}));
  EXPECT_EQ(seen[2], (std::set<int>{3, 5}));
  const llc::LogOutAugmentation mismatched = {{marked(1500, 4), marked(2500, 5), marked(3500, 8)}};
  EXPECT_THROW(llc::leaveOneLogOut(logs, {}, fit, nullptr, nullptr, &mismatched), std::invalid_argument);
}

}  // namespace
